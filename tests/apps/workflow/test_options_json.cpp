// The option tables (visit_fields next to each Options struct) and the JSON reader and writer
// derived from them (apps/workflow/options_json.hpp): round trips, every key settable and
// range-checked, unknown keys and the old spelling `center` rejected.

#include "expect_error.hpp"

#include "apps/workflow/options_json.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace brainshift::workflow {
namespace {

using nlohmann::json;
using tests::expect_error;
using Kind = OptionField::Kind;

/// The options under test with their fields bound to them.
struct Bound {
  constraints::RegistrationOptions options;
  constraints::ComplianceOptions compliance;
  std::vector<OptionField> fields = option_fields(options, compliance);
  Bound() = default;
  Bound(const Bound&) = delete;
};

/// Every member's value (JSON's shortest exact representation), read through the fields' getters
/// and not through a file: compares two option sets member by member.
std::vector<std::string> values(const Bound& b) {
  std::vector<std::string> out;
  for (const OptionField& f : b.fields) out.push_back(f.path + "=" + f.get().dump());
  return out;
}

/// A value of `f` that is in range and differs from `current` (the default).
json other_value(const OptionField& f, const json& current) {
  switch (f.kind) {
    case Kind::NUMBER:
    case Kind::INTEGER: {
      const double v = current.get<double>() == f.range.hi ? f.range.lo : f.range.hi;
      return f.kind == Kind::INTEGER ? json(static_cast<long long>(v)) : json(v);
    }
    case Kind::BOOLEAN:
      return json(!current.get<bool>());
    case Kind::ENUM:
      for (const std::string& c : f.choices)
        if (c != current.get<std::string>()) return json(c);
      break;
    case Kind::VECTOR3:
      return json{1.5, -2.25, 3.0};
  }
  ADD_FAILURE() << f.path << " has no other value";
  return current;
}

/// {"a": {"b": value}} for the path "a.b".
json at_path(const std::string& path, const json& value) {
  json j;
  std::string pointer = "/" + path;
  std::replace(pointer.begin(), pointer.end(), '.', '/');
  j[json::json_pointer(pointer)] = value;
  return j;
}

TEST(OptionsJson, EveryStructIsInTheTableOnceWithAUniquePathAndADoc) {
  const Bound b;
  std::set<std::string> paths;
  for (const OptionField& f : b.fields) {
    EXPECT_TRUE(paths.insert(f.path).second) << "duplicate path " << f.path;
    EXPECT_FALSE(f.doc.empty()) << f.path;  // every option says what it does
    if (f.kind == Kind::NUMBER || f.kind == Kind::INTEGER) {
      EXPECT_LT(f.range.lo, f.range.hi) << f.path;
    }
    EXPECT_EQ(f.path.find("center"), std::string::npos) << f.path;  // one spelling: centre
  }
  // One key of each table (registration, rigid, global start, shift search, dura, filters,
  // step, PGS, noise, compliance) must be there: a table left out of visit_fields is a bug.
  for (const char* p :
       {"rigid.enabled", "rigid.loss", "global_start.max_translation_mm", "shift_search.radius_mm",
        "shift_search.stage_iterations", "constraints.dura", "craniotomy.centre_mm",
        "filter.vessels.max_per_tet", "filter.footprint.max_per_tet", "solver.trust_region_mm",
        "solver.pgs_tolerance", "noise.criterion", "solver.compliance_budget_mib",
        "pairing.refine_distance_mm", "acceptance.max_scatter_mm"})
    EXPECT_TRUE(paths.count(p)) << p;
  // 97 options on 2026-12-02 (16 of RegistrationOptions itself, 81 in the ten nested tables): a
  // table that lost its fields (a visit_fields emptied by a merge) shows here.
  EXPECT_GE(b.fields.size(), 90u);
}

TEST(OptionsJson, DefaultAndChangedOptionsRoundTripExactly) {
  // Defaults → JSON → fresh defaults: equal member by member (17-digit values).
  {
    const Bound a;
    const json j = write_option_fields(a.fields);
    Bound b;
    read_option_fields(j, "defaults.json", b.fields);
    EXPECT_EQ(values(a), values(b));
  }
  // Every field changed to another in-range value → JSON → fresh defaults: the changed values.
  Bound a;
  for (const OptionField& f : a.fields) f.set(other_value(f, f.get()), "changed.json");
  const json j = write_option_fields(a.fields);
  Bound b;
  read_option_fields(j, "changed.json", b.fields);
  EXPECT_EQ(values(a), values(b));
  EXPECT_NE(values(b), values(Bound()));
  // The writer's JSON is the same scene as options_to_json.
  EXPECT_EQ(options_to_json(b.options, b.compliance), j);
}

TEST(OptionsJson, EveryKeyIsSettableAloneAndOutOfRangeIsRejected) {
  const Bound defaults;
  const std::vector<std::string> default_values = values(defaults);
  for (std::size_t i = 0; i < defaults.fields.size(); ++i) {
    const OptionField& d = defaults.fields[i];
    SCOPED_TRACE(d.path);
    // Settable: only this member changes (no two keys share a member, none is ignored).
    {
      Bound b;
      const json v = other_value(d, d.get());
      read_option_fields(at_path(d.path, v), "one.json", b.fields);
      EXPECT_EQ(b.fields[i].get(), v);
      std::vector<std::string> expected = default_values;
      expected[i] = d.path + "=" + v.dump();
      EXPECT_EQ(values(b), expected);
    }
    // Rejected: out of range (both sides), wrong type, unknown name; the message names the
    // file and the key.
    Bound b;
    std::string quoted = "'";  // appended: GCC 12 warns falsely (-Wrestrict) on "'" + string
    quoted += d.path;
    quoted += '\'';
    const auto rejects = [&](const json& v, const char* what) {
      expect_error([&] { read_option_fields(at_path(d.path, v), "bad.json", b.fields); },
                   {"bad.json", quoted, what});
    };
    switch (d.kind) {
      case Kind::NUMBER:
      case Kind::INTEGER: {
        const double span = d.range.hi - d.range.lo;
        const double above = d.range.hi + std::max(1.0, span);
        const double below = d.range.lo - std::max(1.0, span);
        rejects(d.kind == Kind::INTEGER ? json(static_cast<long long>(above)) : json(above),
                "out of range");
        rejects(d.kind == Kind::INTEGER ? json(static_cast<long long>(below)) : json(below),
                "out of range");
        rejects(json("3"), d.kind == Kind::INTEGER ? "must be an integer" : "must be a number");
        if (d.kind == Kind::INTEGER) rejects(json(2.5), "must be an integer");
        break;
      }
      case Kind::BOOLEAN:
        rejects(json(1), "must be true or false");
        break;
      case Kind::ENUM:
        rejects(json("no_such_name"), "is not one of");
        rejects(json(1), "must be a string");
        break;
      case Kind::VECTOR3:
        rejects(json{1.0, 2.0}, "array of 3 numbers");
        break;
    }
    EXPECT_EQ(values(b), default_values);  // a rejected value changes nothing
  }
}

TEST(OptionsJson, UnknownKeysAndTheOldSpellingAreRejectedNamingThem) {
  Bound b;
  const auto read = [&](const char* text) {
    read_option_fields(json::parse(text), "opts.json", b.fields, {"mesh"});
  };
  expect_error([&] { read(R"({"solver": {"pgs_tol": 1e-3}})"); },
               {"opts.json", "unknown key 'solver.pgs_tol'", "known here:", "pgs_tolerance",
                "trust_region_mm"});
  expect_error([&] { read(R"({"rigid": {"enable": true}})"); },
               {"opts.json", "unknown key 'rigid.enable'", "enabled", "loss_scale_mm"});
  expect_error([&] { read(R"({"filter": {"vessels": {"max_per_cell": 3}}})"); },
               {"unknown key 'filter.vessels.max_per_cell'", "max_per_tet"});
  expect_error([&] { read(R"({"mesh_size": 3})"); },
               {"unknown key 'mesh_size'", "mesh", "solver", "noise"});
  expect_error([&] { read(R"({"craniotomy": {"center_mm": [0, 0, 1]}})"); },
               {"opts.json", "'craniotomy.center_mm' is spelled 'craniotomy.centre_mm'"});
  expect_error([&] { read(R"({"solver": 3})"); }, {"'solver' must be an object"});
  EXPECT_NO_THROW(read(R"({"mesh": "elsewhere.vtu", "solver": {"pgs_tolerance": 1e-3}})"));
  EXPECT_EQ(b.options.step.pgs.tolerance, 1e-3);
  // Integers stay integers in the written scene; MiB is the budget's unit.
  const json j = write_option_fields(b.fields);
  EXPECT_TRUE(j["solver"]["max_iterations"].is_number_integer());
  EXPECT_EQ(j["solver"]["compliance_budget_mib"].get<double>(), 512.0);
}

TEST(OptionsJson, EnumNameTablesAgreeWithToString) {
  // One spelling per enum value: the tables (scene) and to_string (reports) say the same.
  for (const auto& n : enum_names(constraints::Mechanics{}))
    EXPECT_EQ(constraints::to_string(n.value), n.name);
  for (const auto& n : enum_names(constraints::ConstraintSolver{}))
    EXPECT_EQ(constraints::to_string(n.value), n.name);
  for (const auto& n : enum_names(constraints::ComplianceStrategy{}))
    EXPECT_EQ(constraints::to_string(n.value), n.name);
  for (const auto& n : enum_names(constraints::NoiseCriterion{}))
    EXPECT_EQ(constraints::to_string(n.value), n.name);
  for (const auto& n : enum_names(constraints::DuraOptions::Mode{}))
    EXPECT_EQ(constraints::to_string(n.value), n.name);
  EXPECT_EQ(core::enum_from_string<constraints::RigidInitOptions::Loss>("cauchy"),
            constraints::RigidInitOptions::Loss::CAUCHY);
  EXPECT_FALSE(core::enum_from_string<constraints::Mechanics>("Warped"));  // exact spelling
}

}  // namespace
}  // namespace brainshift::workflow
