#pragma once
/// @file
/// @brief Turns VTK's error output into one-line brainshift errors: while a VtkErrorCapture is
/// alive, VTK errors and warnings are not printed (VTK prints several lines per error) and the
/// first error is kept.

#include <vtkOutputWindow.h>
#include <vtkSmartPointer.h>

#include <mutex>
#include <string>

namespace brainshift::imaging {

/// While alive, VTK's errors and warnings go nowhere but here; the first error is kept for a
/// one-line exception. Parser errors come from objects we cannot attach observers to, hence the
/// process-wide output window and logger settings, restored on destruction. A capture holds a
/// process-wide (recursive) lock while alive, so threads whose VTK calls all run inside a capture
/// take turns (e.g. the result files written on two threads): each sees only its own errors.
/// VTK used outside a capture on another thread meanwhile is not serialised.
class VtkErrorCapture {
 public:
  VtkErrorCapture();
  ~VtkErrorCapture();
  VtkErrorCapture(const VtkErrorCapture&) = delete;
  VtkErrorCapture& operator=(const VtkErrorCapture&) = delete;

  /// True once VTK reported an error.
  [[nodiscard]] bool failed() const;
  /// The first error, without VTK's "ERROR: In file, line N" preamble and class prefix.
  [[nodiscard]] const std::string& message() const;

 private:
  class Window;
  std::unique_lock<std::recursive_mutex> m_lock;  ///< first: taken before, released after the rest
  vtkSmartPointer<vtkOutputWindow> m_previous_window;
  vtkSmartPointer<Window> m_window;
  int m_previous_cutoff;
};

}  // namespace brainshift::imaging
