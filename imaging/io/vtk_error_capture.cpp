#include "imaging/io/vtk_error_capture.hpp"

#include <vtkLogger.h>

#include <sstream>

namespace brainshift::imaging {
namespace {

/// The message of a VTK error text: the line after VTK's "ERROR: In file, line N" preamble,
/// without the "vtkClass (0x…): " prefix.
std::string vtk_error_message(const char* text) {
  std::istringstream in(text != nullptr ? text : "");
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line.rfind("ERROR: In ", 0) == 0) continue;
    if (const auto colon = line.find("): "); colon != std::string::npos) line.erase(0, colon + 3);
    return line;
  }
  return "VTK error";
}

/// Serialises the captures of all threads (see the class).
std::recursive_mutex& capture_mutex() {
  static std::recursive_mutex m;
  return m;
}

}  // namespace

class VtkErrorCapture::Window : public vtkOutputWindow {
 public:
  static Window* New() { return new Window; }
  void DisplayText(const char* /*text*/) override {}
  void DisplayErrorText(const char* text) override {
    if (first_error.empty()) first_error = vtk_error_message(text);
  }
  void DisplayWarningText(const char* /*text*/) override {}
  void DisplayGenericWarningText(const char* /*text*/) override {}
  void DisplayDebugText(const char* /*text*/) override {}
  std::string first_error;
};

VtkErrorCapture::VtkErrorCapture()
    : m_lock(capture_mutex()),
      m_previous_window(vtkOutputWindow::GetInstance()),
      m_previous_cutoff(vtkLogger::GetCurrentVerbosityCutoff()) {
  vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
  m_window = vtkSmartPointer<Window>::New();
  vtkOutputWindow::SetInstance(m_window);
}

VtkErrorCapture::~VtkErrorCapture() {
  vtkOutputWindow::SetInstance(m_previous_window);
  vtkLogger::SetStderrVerbosity(static_cast<vtkLogger::Verbosity>(m_previous_cutoff));
}

bool VtkErrorCapture::failed() const { return !m_window->first_error.empty(); }
const std::string& VtkErrorCapture::message() const { return m_window->first_error; }

}  // namespace brainshift::imaging
