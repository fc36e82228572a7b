// Names of the registration's enums (registration.hpp), as written to results and reports.
#include "constraints/registration/registration_types.hpp"
#include "core/error.hpp"

namespace brainshift::constraints {

std::string to_string(RegistrationStop stop) {
  switch (stop) {
    case RegistrationStop::CONVERGED:
      return "converged";
    case RegistrationStop::MAX_ITERATIONS:
      return "max_iterations";
    case RegistrationStop::NO_DATA:
      return "no_data";
    case RegistrationStop::NOT_SETTLING:
      return "not_settling";
    case RegistrationStop::DIVERGED:
      return "diverged";
    case RegistrationStop::INSUFFICIENT_DATA:
      return "insufficient_data";
    case RegistrationStop::AMBIGUOUS_POSE:
      return "ambiguous_pose";
  }
  BS_UNREACHABLE();
}

std::string to_string(StageKind kind) {
  switch (kind) {
    case StageKind::HELD:
      return "held";
    case StageKind::FREE:
      return "free";
    case StageKind::SMOOTH:
      return "smooth";
  }
  BS_UNREACHABLE();
}

std::string to_string(PairingMode mode) {
  switch (mode) {
    case PairingMode::FRESH:
      return "fresh";
    case PairingMode::HELD:
      return "held";
    case PairingMode::FROZEN:
      return "frozen";
  }
  BS_UNREACHABLE();
}

std::string to_string(TrustDecision d) {
  switch (d) {
    case TrustDecision::NONE:
      return "none";
    case TrustDecision::GROW:
      return "grow";
    case TrustDecision::HOLD:
      return "hold";
    case TrustDecision::SHRINK:
      return "shrink";
    case TrustDecision::DAMP:
      return "damp";
  }
  BS_UNREACHABLE();
}

std::string to_string(StageStop stop) {
  switch (stop) {
    case StageStop::SETTLED:
      return "settled";
    case StageStop::ITERATION_CAP:
      return "iteration_cap";
    case StageStop::NOT_SETTLING:
      return "not_settling";
    case StageStop::DIVERGED:
      return "diverged";
    case StageStop::STALLED:
      return "stalled";
  }
  BS_UNREACHABLE();
}

}  // namespace brainshift::constraints
