#include "apps/workflow/options_json.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string_view>
#include <type_traits>

namespace brainshift::workflow {
namespace {

using nlohmann::json;
using Kind = OptionField::Kind;

/// The unit a name states by its suffix, for messages ("" when none).
std::string unit_of(const std::string& path) {
  static const std::pair<std::string_view, std::string_view> kUnits[] = {
      {"_mm", "mm"}, {"_deg", "deg"}, {"_mib", "MiB"}, {"_mn", "mN"}, {"_kpa", "kPa"}};
  for (const auto& [suffix, unit] : kUnits)
    if (path.size() > suffix.size() && path.ends_with(suffix)) return std::string(unit);
  return "";
}

std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

/// A number of `path` from `value`, checked against the range (error names the file and path).
double checked_number(const json& value, const std::string& file, const std::string& path,
                      core::Range r, bool integer) {
  const std::string unit = unit_of(path);
  if (integer)
    BS_VERIFY(value.is_number_integer(), file << ": '" << path << "' must be an integer");
  else
    BS_VERIFY(value.is_number(), file << ": '" << path << "' must be a number"
                                      << (unit.empty() ? "" : " (" + unit + ")"));
  const double v = value.get<double>();
  BS_VERIFY(std::isfinite(v) && v >= r.lo && v <= r.hi,
            file << ": '" << path << "' = " << (integer ? value.dump() : number_text(v)) << unit
                 << " is out of range [" << r.lo << ", " << r.hi << "]");
  return v;
}

/// The visitor that turns a table (visit_fields) into OptionFields bound to the members.
class Collector {
 public:
  explicit Collector(std::vector<OptionField>& out) : m_out(out) {}

  void operator()(std::string_view name, double& m, core::Range r, std::string_view doc) {
    OptionField& f = add(name, Kind::NUMBER, doc);
    f.range = r;
    f.set = [m = &m, r, p = f.path](const json& v, const std::string& file) {
      *m = checked_number(v, file, p, r, false);
    };
    f.get = [m = &m] { return json(*m); };
  }
  void operator()(std::string_view name, int& m, core::Range r, std::string_view doc) {
    OptionField& f = add(name, Kind::INTEGER, doc);
    f.range = r;
    f.set = [m = &m, r, p = f.path](const json& v, const std::string& file) {
      *m = static_cast<int>(checked_number(v, file, p, r, true));
    };
    f.get = [m = &m] { return json(*m); };
  }
  void operator()(std::string_view name, core::MebiBytes m, core::Range r, std::string_view doc) {
    OptionField& f = add(name, Kind::NUMBER, doc);
    f.range = r;
    f.set = [bytes = &m.bytes, r, p = f.path](const json& v, const std::string& file) {
      *bytes = static_cast<std::size_t>(checked_number(v, file, p, r, false) * 1048576.0);
    };
    f.get = [bytes = &m.bytes] { return json(static_cast<double>(*bytes) / 1048576.0); };
  }
  void operator()(std::string_view name, bool& m, std::string_view doc) {
    OptionField& f = add(name, Kind::BOOLEAN, doc);
    f.set = [m = &m, p = f.path](const json& v, const std::string& file) {
      *m = boolean(v, file, p);
    };
    f.get = [m = &m] { return json(*m); };
  }
  template <class E>
  void operator()(std::string_view name, core::EnumFlag<E> flag, std::string_view doc) {
    OptionField& f = add(name, Kind::BOOLEAN, doc);
    f.set = [m = &flag.value, on = flag.on, off = flag.off, p = f.path](
                const json& v, const std::string& file) { *m = boolean(v, file, p) ? on : off; };
    f.get = [m = &flag.value, on = flag.on] { return json(*m == on); };
  }
  template <class E>
  requires std::is_enum_v<E>
  void operator()(std::string_view name, E& m, std::string_view doc) {
    OptionField& f = add(name, Kind::ENUM, doc);
    std::string choices;
    for (const auto& n : enum_names(E{})) {
      f.choices.emplace_back(n.name);
      if (!choices.empty()) choices += '|';
      choices += n.name;
    }
    f.set = [m = &m, p = f.path, choices](const json& v, const std::string& file) {
      BS_VERIFY(v.is_string(), file << ": '" << p << "' must be a string");
      const auto e = core::enum_from_string<E>(v.get<std::string>());
      BS_VERIFY(e, file << ": '" << p << "' = \"" << v.get<std::string>() << "\" is not one of "
                        << choices);
      *m = *e;
    };
    f.get = [m = &m] { return json(core::enum_to_string(*m)); };
  }
  void operator()(std::string_view name, Vector3d& m, std::string_view doc) {
    OptionField& f = add(name, Kind::VECTOR3, doc);
    f.set = [m = &m, p = f.path](const json& a, const std::string& file) {
      BS_VERIFY(
          a.is_array() && a.size() == 3 && a[0].is_number() && a[1].is_number() && a[2].is_number(),
          file << ": '" << p << "' must be an array of 3 numbers" << unit_text(p));
      const Vector3d x(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
      BS_VERIFY(x.allFinite(), file << ": '" << p << "' must be finite");
      *m = x;
    };
    f.get = [m = &m] { return json{m->x(), m->y(), m->z()}; };
  }
  template <class S>
  void nest(std::string_view prefix, S& sub) {
    const std::string saved = m_prefix;
    m_prefix += prefix;
    visit_fields(sub, *this);
    m_prefix = saved;
  }

 private:
  static bool boolean(const json& v, const std::string& file, const std::string& path) {
    BS_VERIFY(v.is_boolean(), file << ": '" << path << "' must be true or false");
    return v.get<bool>();
  }
  static std::string unit_text(const std::string& path) {
    const std::string u = unit_of(path);
    return u.empty() ? "" : " (" + u + ")";
  }
  OptionField& add(std::string_view name, Kind kind, std::string_view doc) {
    OptionField f;
    f.path = m_prefix + std::string(name);
    f.kind = kind;
    f.doc = std::string(doc);
    m_out.push_back(std::move(f));
    return m_out.back();
  }
  std::vector<OptionField>& m_out;
  std::string m_prefix;
};

/// The keys directly under `prefix` (e.g. "solver.") that some field path continues with.
std::set<std::string> keys_under(const std::vector<OptionField>& fields,
                                 const std::string& prefix) {
  std::set<std::string> keys;
  for (const OptionField& f : fields)
    if (f.path.starts_with(prefix)) {
      const std::string rest = f.path.substr(prefix.size());
      keys.insert(rest.substr(0, rest.find('.')));
    }
  return keys;
}

/// Keys earlier versions read that are no longer scene keys, and why. `rigid.enabled` (old
/// scenes, which `prepare` wrote with it) is the old spelling of `start` and still read.
struct RetiredKey {
  std::string_view path;
  std::string_view why;
};
constexpr std::string_view kRemoved = "was removed with the code it set";
constexpr std::string_view kInternal =
    "is not a scene key (a constant of the method; `brainshift options` lists the scene keys)";
constexpr RetiredKey kRetired[] = {
    {"rigid.loss",
     "was removed with the Ceres ICP start it set (the global start refines the pose)"},
    {"rigid.loss_scale_mm", "was removed with the Ceres ICP start it set"},
    {"rigid.max_icp_iterations", "was removed with the Ceres ICP start it set"},
    {"rigid.max_pair_distance_mm", "was removed with the Ceres ICP start it set"},
    {"rigid.footprint_weight", "was removed with the Ceres ICP start it set"},
    {"rigid.convergence_mm", "was removed with the Ceres ICP start it set"},
    {"rigid.max_solver_iterations", "was removed with the Ceres ICP start it set"},
    {"rigid.weak_dof_ratio", "was removed with the Ceres ICP start it set"},
    {"solver.relaxation", kRemoved},
    {"solver.fold_correction", kRemoved},
    {"noise.smooth_neighbours", kRemoved},
    {"global_start.coarse_step_mm", kInternal},
    {"global_start.coarse_kernel_mm", kInternal},
    {"global_start.fine_kernel_mm", kInternal},
    {"global_start.voxel_mm", kInternal},
    {"global_start.coarse_points", kInternal},
    {"global_start.max_points", kInternal},
    {"global_start.candidates", kInternal},
    {"global_start.min_gain", kInternal},
    {"global_start.significance_block_mm", kInternal},
    {"global_start.refine_distance_mm", kInternal},
    {"global_start.loss_scale_mm", kInternal},
    {"global_start.refine_iterations", kInternal},
    {"global_start.solver_iterations", kInternal},
    {"global_start.convergence_mm", kInternal},
    {"global_start.bulk_min_mm", kInternal},
    {"global_start.bulk_sinks", kInternal},
    {"shift_search.coarse_step_mm", kInternal},
    {"shift_search.coarse_kernel_mm", kInternal},
    {"shift_search.fine_kernel_mm", kInternal},
    {"shift_search.voxel_mm", kInternal},
    {"shift_search.max_points", kInternal},
    {"shift_search.min_gain", kInternal},
    {"shift_search.stage_iterations", kInternal},
    {"shift_search.load_basis", kInternal},
    {"shift_search.as_load", kInternal},
    {"noise.criterion", kInternal},
    {"noise.consider_start", kInternal},
    {"noise.start_is_bulk_state", kInternal},
    {"noise.one_standard_error", kInternal},
    {"noise.paired_test", kInternal},
    {"noise.change_factor", kInternal},
    {"noise.max_rows", kInternal},
    {"solver.plausible_violation_mm", kInternal},
    {"solver.pgs_lambda_max_mn", kInternal},
    {"solver.pgs_stall_window", kInternal},
    {"solver.pgs_null_row_tolerance", kInternal},
    {"solver.pgs_active_set_max_changes", kInternal},
    {"solver.compliance_precompute", kInternal},
    {"solver.compliance_precompute_chunk", kInternal},
    {"uncertainty.scale_confidence", kInternal},
    {"uncertainty.rigid_term", kInternal},
    {"uncertainty.pose_confounded", kInternal},
};

/// `rigid.enabled`, the old spelling of `start` (true: rigid, false: identity); true when `path`
/// was it and has been read.
bool read_old_start(const json& value, const std::string& file, const std::string& path,
                    const std::vector<OptionField>& fields) {
  if (path != "rigid.enabled") return false;
  BS_VERIFY(value.is_boolean(), file << ": '" << path << "' must be true or false");
  const auto start = std::find_if(fields.begin(), fields.end(),
                                  [](const OptionField& f) { return f.path == "start"; });
  BS_VERIFY(start != fields.end(), file << ": '" << path << "' has no 'start' to set");
  start->set(json(value.get<bool>() ? "rigid" : "identity"), file);
  return true;
}

/// Whether `path` or an object above it is retired (old spellings of a group: "rigid").
bool retired_group(const std::string& path) {
  for (const RetiredKey& r : kRetired)
    if (r.path.starts_with(path + ".")) return true;
  return false;
}

std::string joined(const std::set<std::string>& keys) {
  std::string list;
  for (const auto& k : keys) list += (list.empty() ? "" : ", ") + k;
  return list;
}

void read_object(const json& j, const std::string& file, const std::string& prefix,
                 const std::vector<OptionField>& fields, const std::set<std::string>& other_keys) {
  const std::string where = prefix.empty() ? "the top level" : prefix.substr(0, prefix.size() - 1);
  BS_VERIFY(j.is_object(), file << ": '" << where << "' must be an object");
  std::set<std::string> known = keys_under(fields, prefix);
  if (prefix.empty()) known.insert(other_keys.begin(), other_keys.end());
  for (const auto& [key, value] : j.items()) {
    const std::string path = prefix + key;
    if (prefix.empty() && other_keys.count(key)) continue;  // the caller's own key
    const auto field = std::find_if(fields.begin(), fields.end(),
                                    [&](const OptionField& f) { return f.path == path; });
    if (field != fields.end()) {
      field->set(value, file);
      continue;
    }
    if (read_old_start(value, file, path, fields)) continue;
    for (const RetiredKey& r : kRetired)
      BS_VERIFY(r.path != path, file << ": '" << path << "' " << r.why);
    if (known.count(key) || retired_group(path)) {  // an object of fields
      BS_VERIFY(value.is_object(), file << ": '" << path << "' must be an object (keys: "
                                        << joined(keys_under(fields, path + ".")) << ")");
      read_object(value, file, path + ".", fields, other_keys);
      continue;
    }
    if (const auto at = key.find("center"); at != std::string::npos) {
      const std::string renamed = std::string(key).replace(at, 6, "centre");
      BS_VERIFY(!known.count(renamed), file << ": '" << path << "' is spelled '" << prefix
                                            << renamed << "' (one spelling: centre)");
    }
    BS_VERIFY(false,
              file << ": unknown key '" << path << "' (known here: " << joined(known) << ")");
  }
}

}  // namespace

std::vector<OptionField> option_fields(constraints::RegistrationOptions& options,
                                       constraints::ComplianceOptions& compliance) {
  std::vector<OptionField> fields;
  Collector c(fields);
  visit_fields(options, c);
  c.nest("solver.compliance_", compliance);
  return fields;
}

void read_option_fields(const json& j, const std::string& file,
                        const std::vector<OptionField>& fields,
                        const std::set<std::string>& other_keys) {
  read_object(j, file, "", fields, other_keys);
}

json write_option_fields(const std::vector<OptionField>& fields) {
  json out = json::object();
  for (const OptionField& f : fields) {
    std::string pointer = "/" + f.path;
    std::replace(pointer.begin(), pointer.end(), '.', '/');
    out[json::json_pointer(pointer)] = f.get();
  }
  return out;
}

json options_to_json(constraints::RegistrationOptions options,
                     constraints::ComplianceOptions compliance) {
  return write_option_fields(option_fields(options, compliance));
}

}  // namespace brainshift::workflow
