#include "apps/workflow/scene_io.hpp"

#include "apps/workflow/options_json.hpp"
#include "core/error.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/io/mesh_io.hpp"
#include "imaging/io/skeleton_io.hpp"
#include "imaging/io/surface_io.hpp"
#include "imaging/vessels/skeleton_graph.hpp"

#include <nlohmann/json.hpp>

#include <fstream>
#include <set>
#include <sstream>

namespace brainshift::workflow {
namespace {

using imaging::read_node_list;
using imaging::read_skeleton_vtp;
using imaging::read_surface_vtp;
using imaging::read_tet_mesh;
using imaging::to_skeleton;
using nlohmann::json;

/// A JSON object of the scene's own keys (files, materials, fixed region) being read: checks keys
/// against a known list, types and ranges, and names the file and the dotted key path in every
/// error. The options are read from their tables (options_json.hpp).
class Reader {
 public:
  Reader(const json& j, std::string file, std::string where, std::set<std::string> known)
      : m_j(j), m_file(std::move(file)), m_where(std::move(where)) {
    BS_VERIFY(j.is_object(), m_file << ": " << name("") << " must be an object");
    for (const auto& [k, v] : j.items())
      if (!known.count(k)) {
        std::string list;
        for (const auto& s : known) list += (list.empty() ? "" : ", ") + s;
        BS_VERIFY(false,
                  m_file << ": unknown key '" << name(k) << "' (known here: " << list << ")");
      }
  }
  [[nodiscard]] bool has(const std::string& k) const { return m_j.contains(k); }
  [[nodiscard]] Reader object(const std::string& k, std::set<std::string> known) const {
    return Reader(m_j.at(k), m_file, name(k), std::move(known));
  }
  [[nodiscard]] std::string name(const std::string& k) const {
    return m_where.empty() ? k : (k.empty() ? m_where : m_where + "." + k);
  }
  void number(const std::string& k, double& out, double lo, double hi,
              const char* unit = "") const {
    if (!has(k)) return;
    BS_VERIFY(m_j[k].is_number(),
              m_file << ": '" << name(k) << "' must be a number" << unit_text(unit));
    const double v = m_j[k].get<double>();
    BS_VERIFY(v >= lo && v <= hi, m_file << ": '" << name(k) << "' = " << v << unit
                                         << " is out of range [" << lo << ", " << hi << "]");
    out = v;
  }
  void integer(const std::string& k, int& out, int lo, int hi) const {
    if (!has(k)) return;
    BS_VERIFY(m_j[k].is_number_integer(), m_file << ": '" << name(k) << "' must be an integer");
    const auto v = m_j[k].get<long long>();
    BS_VERIFY(v >= lo && v <= hi, m_file << ": '" << name(k) << "' = " << v << " is out of range ["
                                         << lo << ", " << hi << "]");
    out = static_cast<int>(v);
  }
  [[nodiscard]] std::string text(const std::string& k) const {
    BS_VERIFY(m_j[k].is_string(), m_file << ": '" << name(k) << "' must be a string");
    return m_j[k].get<std::string>();
  }
  [[nodiscard]] Vector3d vector3(const std::string& k) const {
    const json& a = m_j[k];
    BS_VERIFY(
        a.is_array() && a.size() == 3 && a[0].is_number() && a[1].is_number() && a[2].is_number(),
        m_file << ": '" << name(k) << "' must be an array of 3 numbers (mm)");
    return {a[0].get<double>(), a[1].get<double>(), a[2].get<double>()};
  }

 private:
  static std::string unit_text(const char* unit) {
    return *unit ? std::string(" (") + unit + ")" : "";
  }
  const json& m_j;
  std::string m_file;
  std::string m_where;
};

constexpr double kBig = 1e6;

/// The scene's own keys (its files and their settings); every other key is an option.
const std::set<std::string> kSceneFileKeys = {"version",           "mesh",   "materials", "fixed",
                                              "collision_surface", "vessels"};

}  // namespace

std::set<std::string> scene_option_keys() {
  constraints::RegistrationOptions o;
  constraints::ComplianceOptions c;
  std::set<std::string> keys;
  for (const OptionField& f : option_fields(o, c)) keys.insert(f.path.substr(0, f.path.find('.')));
  return keys;
}

void check_scene_options(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::ifstream in(path);
  BS_VERIFY(in.good(), file << ": cannot open the scene options");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    BS_VERIFY(false, file << ": not valid JSON (at byte " << e.byte << ")");
  } catch (const json::exception&) {  // e.g. a number beyond double's range
    BS_VERIFY(false, file << ": not valid JSON (a number out of range)");
  }
  constraints::RegistrationOptions o;
  constraints::ComplianceOptions c;
  read_option_fields(j, file, option_fields(o, c), kSceneFileKeys);
}

std::vector<index_t> nodes_below(const core::TetMesh& mesh, const Vector3d& direction,
                                 double height_mm) {
  BS_VERIFY(direction.norm() > 0 && direction.allFinite(),
            "fixed region: the down direction must be non-zero");
  const Vector3d d = direction.normalized();
  const Eigen::VectorXd depth = mesh.nodes() * d;  // larger = lower
  const double lowest = depth.maxCoeff();
  std::vector<index_t> out;
  for (index_t i = 0; i < mesh.num_nodes(); ++i)
    if (depth[i] >= lowest - height_mm) out.push_back(i);
  return out;
}

Scene read_scene(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::ifstream in(path);
  BS_VERIFY(in.good(), file << ": cannot open the scene file");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    BS_VERIFY(false, file << ": not valid JSON (at byte " << e.byte << ")");
  } catch (const json::exception&) {  // e.g. a number beyond double's range
    BS_VERIFY(false, file << ": not valid JSON (a number out of range)");
  }
  std::set<std::string> top = kSceneFileKeys;
  for (const auto& k : scene_option_keys()) top.insert(k);
  const Reader r(j, file, "", top);
  if (r.has("version")) {
    int version = 1;
    r.integer("version", version, 1, 1);
  }
  BS_VERIFY(r.has("mesh"), file << ": missing key 'mesh' (the tetrahedral mesh, .vtu)");
  // Every option, from the tables next to the Options structs (options_json.hpp), before any
  // file is read: a typo costs no mesh loading.
  Scene s;
  read_option_fields(j, file, option_fields(s.options, s.compliance), kSceneFileKeys);
  const std::filesystem::path dir = path.parent_path();
  auto resolve = [&](const std::string& key) {
    const std::filesystem::path p = r.text(key);
    return p.is_absolute() ? p : dir / p;
  };
  auto with_context = [&](const std::string& key, auto&& load) {
    try {
      return load(resolve(key));
    } catch (const Error& e) {
      BS_VERIFY(false, file << ": '" << key << "': " << e.what());
    }
    BS_UNREACHABLE();
  };
  s.mesh = with_context("mesh", [](const std::filesystem::path& p) { return read_tet_mesh(p); });
  if (r.has("materials")) {
    const Reader m = r.object("materials", {"youngs_modulus_kpa", "poisson_ratio"});
    double E = -1, nu = -1;
    m.number("youngs_modulus_kpa", E, 1e-6, 1e6, "kPa");
    m.number("poisson_ratio", nu, 0.0, 0.4999);
    Eigen::VectorXd Es = s.mesh.youngs_modulus(), nus = s.mesh.poisson_ratio();
    if (E > 0) Es.setConstant(E);
    if (nu >= 0) nus.setConstant(nu);
    s.mesh = core::TetMesh(s.mesh.nodes(), s.mesh.tets(), Es, nus);
  }
  // Fixed region: a node list, or the nodes near the bottom (default: 15 mm along −z, RAS).
  if (r.has("fixed")) {
    const Reader f = r.object("fixed", {"nodes", "below"});
    BS_VERIFY(f.has("nodes") != f.has("below"),
              file << ": 'fixed' needs exactly one of 'nodes' or 'below'");
    if (f.has("nodes")) {
      const std::filesystem::path p = f.text("nodes");
      s.fixed_nodes = read_node_list(p.is_absolute() ? p : dir / p, s.mesh.num_nodes());
    } else {
      const Reader b = f.object("below", {"direction", "height_mm"});
      Vector3d down(0, 0, -1);
      double height = 15.0;
      if (b.has("direction")) down = b.vector3("direction");
      b.number("height_mm", height, 0, kBig, "mm");
      s.fixed_nodes = nodes_below(s.mesh, down, height);
    }
  } else {
    s.fixed_nodes = nodes_below(s.mesh, Vector3d(0, 0, -1), 15.0);
  }
  BS_VERIFY(s.fixed_nodes.size() >= 3, file << ": the fixed region has " << s.fixed_nodes.size()
                                            << " nodes; at least 3 are needed to hold the model");
  if (r.has("collision_surface"))
    s.surface = with_context("collision_surface",
                             [](const std::filesystem::path& p) { return read_surface_vtp(p); });
  if (r.has("vessels"))
    s.skeleton = with_context("vessels", [](const std::filesystem::path& p) {
      return to_skeleton(read_skeleton_vtp(p));
    });

  auto& o = s.options;
  BS_VERIFY(o.dura.mode == constraints::DuraOptions::Mode::NONE || s.surface.triangles.rows() > 0,
            file << ": dura contact needs a 'collision_surface'");
  const std::string invalid = o.validate();
  BS_VERIFY(invalid.empty(), file << ": " << invalid);
  return s;
}

}  // namespace brainshift::workflow
