#pragma once
/// @file
/// @brief Options ⇄ JSON, derived from the option tables (`visit_fields` next to each Options
/// struct; core/option_fields.hpp): one flat list of fields, each with its scene path
/// ("solver.pgs_tolerance"), kind, range, documentation and a reader and writer bound to the
/// member. The scene reader (scene_io.hpp) and `prepare --scene-options` read through it; the
/// writer gives every option with its current value. Units: those the names state (mm, deg, MiB,
/// mN); positions world RAS.

#include "constraints/registration/registration.hpp"
#include "constraints/solver/compliance_operator.hpp"

#include <nlohmann/json.hpp>

#include <functional>
#include <set>
#include <string>
#include <vector>

namespace brainshift::workflow {

/// One option, bound to a member of the options it was collected from.
struct OptionField {
  enum class Kind { NUMBER, INTEGER, BOOLEAN, ENUM, VECTOR3 };
  std::string path;  ///< dotted path in the scene, e.g. "filter.vessels.max_per_tet"
  Kind kind = Kind::NUMBER;
  core::Range range;                 ///< NUMBER, INTEGER: accepted values, in the unit of the name
  std::vector<std::string> choices;  ///< ENUM: the names, in table order
  std::string doc;                   ///< one line
  /// Checks `value` (type, range, name) and stores it in the member.
  /// \throws brainshift::Error "FILE: 'PATH' ..." (one line) when it does not fit.
  std::function<void(const nlohmann::json& value, const std::string& file)> set;
  /// The member's value as JSON.
  std::function<nlohmann::json()> get;
};

/// Every field of the registration options and of the compliance options (scene paths:
/// RegistrationOptions' own, ComplianceOptions under "solver.compliance_"). The fields refer to
/// `options` and `compliance`, which must outlive them.
std::vector<OptionField> option_fields(constraints::RegistrationOptions& options,
                                       constraints::ComplianceOptions& compliance);

/// Sets the fields named in `j` (any subset; nested objects by path) and leaves the others.
/// `other_keys`: top-level keys that are not options but are allowed (the scene's files), skipped.
/// \throws brainshift::Error, one line naming `file` and the dotted key: an unknown key (listing
/// the known keys of that object), the old spelling `center` (with the new one), a wrong type,
/// a value out of range or not one of the enum's names.
void read_option_fields(const nlohmann::json& j, const std::string& file,
                        const std::vector<OptionField>& fields,
                        const std::set<std::string>& other_keys = {});

/// Every field's current value, nested by path (the inverse of read_option_fields).
nlohmann::json write_option_fields(const std::vector<OptionField>& fields);

/// The options as JSON, every key present: a scene's option part.
nlohmann::json options_to_json(constraints::RegistrationOptions options,
                               constraints::ComplianceOptions compliance);

}  // namespace brainshift::workflow
