#pragma once
/// @file
/// @brief Error tiers: BS_VERIFY (always on, inputs and public preconditions; throws
/// brainshift::Error), BS_ASSERT (debug-only internal invariants), BS_UNREACHABLE.
///
/// Numerical outcomes (non-convergence, indefinite matrices) are statuses in Result structs,
/// never exceptions.

#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace brainshift {

/// The one exception type of brainshift: a message a user can act on.
/// what() is the one-line message for users; where() is the throw site for developers.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message, std::string where = {})
      : std::runtime_error(message), m_where(std::move(where)) {}
  /// "file:line" of the BS_VERIFY that threw, empty when thrown directly.
  [[nodiscard]] const std::string& where() const noexcept { return m_where; }

 private:
  std::string m_where;
};

namespace detail {
[[noreturn]] void throw_error(const char* file, int line, const std::string& message);
}  // namespace detail

}  // namespace brainshift

/// Throws brainshift::Error with `msg` (a stream expression) when `cond` is false.
#define BS_VERIFY(cond, msg)                                                          \
  do {                                                                                \
    if (!(cond)) {                                                                    \
      std::ostringstream bs_verify_stream_;                                           \
      bs_verify_stream_ << msg;                                                       \
      ::brainshift::detail::throw_error(__FILE__, __LINE__, bs_verify_stream_.str()); \
    }                                                                                 \
  } while (false)

/// Throws brainshift::Error unconditionally.
#define BS_THROW(msg) BS_VERIFY(false, msg)

#ifdef NDEBUG
#define BS_ASSERT(cond, msg) ((void)0)
#else
#define BS_ASSERT(cond, msg) BS_VERIFY(cond, "internal error: " << msg)
#endif

#define BS_UNREACHABLE() BS_THROW("internal error: unreachable code reached")
