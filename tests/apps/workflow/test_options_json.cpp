// The option tables (visit_fields next to each Options struct) and the JSON reader and writer
// derived from them (apps/workflow/options_json.hpp): round trips, every key settable and
// range-checked, unknown keys and the old spelling `center` rejected, retired keys named as such;
// the printed table (`brainshift options`, docs/OPTIONS.md) generated from the same fields.

#include "expect_error.hpp"
#include "tests/config.hpp"

#include "apps/workflow/options_json.hpp"
#include "apps/workflow/options_table.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
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
  // One key of each table (registration, global start, shift search, dura, filters, step, PGS,
  // noise, uncertainty, compliance) must be there: a table left out of visit_fields is a bug.
  for (const char* p :
       {"start", "global_start.max_translation_mm", "shift_search.radius_mm", "constraints.dura",
        "craniotomy.centre_mm", "filter.vessels.max_per_tet", "filter.footprint.max_per_tet",
        "solver.trust_region_mm", "solver.pgs_tolerance", "noise.paired_test_z",
        "uncertainty.calibration", "solver.compliance_budget_mib", "pairing.refine_distance_mm",
        "acceptance.max_scatter_mm"})
    EXPECT_TRUE(paths.count(p)) << p;
  // The product's keys only (issue 31: at most 60; 59 when the tables were pruned, from 108): a
  // key added without removing one shows here, and so does a table that lost its fields (a
  // visit_fields emptied by a merge) below 50.
  EXPECT_LE(b.fields.size(), 60u);
  EXPECT_GE(b.fields.size(), 50u);
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
  expect_error([&] { read(R"({"noise": {"enable": true}})"); },
               {"opts.json", "unknown key 'noise.enable'", "enabled", "paired_test_z"});
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
  for (const auto& n : enum_names(constraints::RigidStart{}))
    EXPECT_EQ(core::enum_from_string<constraints::RigidStart>(n.name), n.value);
  EXPECT_FALSE(core::enum_from_string<constraints::Mechanics>("Warped"));  // exact spelling
}

TEST(OptionsJson, OldScenesStartAsTheySaidAndRetiredKeysSayWhy) {
  // `rigid.enabled` is how scenes of earlier versions (written by prepare) chose the start.
  {
    Bound b;
    ASSERT_EQ(b.options.start, constraints::RigidStart::RIGID);  // the product's default
    read_option_fields(json::parse(R"({"rigid": {"enabled": false}})"), "old.json", b.fields);
    EXPECT_EQ(b.options.start, constraints::RigidStart::IDENTITY);
    read_option_fields(json::parse(R"({"rigid": {"enabled": true}})"), "old.json", b.fields);
    EXPECT_EQ(b.options.start, constraints::RigidStart::RIGID);
  }
  Bound b;
  const auto read = [&](const char* text) {
    read_option_fields(json::parse(text), "opts.json", b.fields);
  };
  expect_error([&] { read(R"({"rigid": {"enabled": "yes"}})"); },
               {"opts.json", "'rigid.enabled' must be true or false"});
  // Removed code: the key is named and said to be gone, not merely unknown.
  expect_error([&] { read(R"({"rigid": {"loss": "cauchy"}})"); },
               {"opts.json", "'rigid.loss'", "was removed"});
  expect_error([&] { read(R"({"solver": {"fold_correction": true}})"); },
               {"opts.json", "'solver.fold_correction'", "was removed"});
  // A constant of the method that is no longer a scene key.
  expect_error([&] { read(R"({"noise": {"criterion": "gcv"}})"); },
               {"opts.json", "'noise.criterion'", "is not a scene key", "brainshift options"});
  expect_error([&] { read(R"({"global_start": {"coarse_step_mm": 2}})"); },
               {"opts.json", "'global_start.coarse_step_mm'", "is not a scene key"});
}

TEST(OptionsTable, OneLinePerKeyWithTheDefaultTheReaderWouldRead) {
  const Bound b;
  const std::vector<OptionRow> rows = option_rows();
  ASSERT_EQ(rows.size(), b.fields.size());
  // Each printed default, read back as that key's value, gives the library's default (so the
  // table's defaults are what a scene that spells them out gets).
  json all = json::object();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].path, b.fields[i].path);
    all.merge_patch(at_path(rows[i].path, json::parse(rows[i].default_value)));
  }
  Bound c;
  for (const OptionField& f : c.fields) f.set(other_value(f, f.get()), "changed.json");
  read_option_fields(all, "table.json", c.fields);
  EXPECT_EQ(values(c), values(b));
  // The text form: one line per key, starting with its path, in the same order.
  std::istringstream text(options_text());
  std::size_t i = 0;
  for (std::string line; std::getline(text, line); ++i) {
    ASSERT_LT(i, rows.size()) << line;
    EXPECT_EQ(line.rfind(rows[i].path + " ", 0), 0u) << line;
    EXPECT_NE(line.find(rows[i].doc), std::string::npos) << line;
  }
  EXPECT_EQ(i, rows.size());
}

TEST(OptionsTable, DocsOptionsMdIsTheGeneratedTable) {
  // docs/OPTIONS.md is `brainshift options --markdown`: regenerate it with
  //   build/apps/brainshift options --markdown > docs/OPTIONS.md
  // when an option changes.
  const std::filesystem::path doc = std::filesystem::path(tests::source_dir) / "docs/OPTIONS.md";
  std::ifstream in(doc);
  ASSERT_TRUE(in.good()) << doc;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, options_markdown())
      << doc << " differs from `brainshift options --markdown`; regenerate it";
}

}  // namespace
}  // namespace brainshift::workflow
