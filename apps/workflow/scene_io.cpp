#include "apps/workflow/scene_io.hpp"

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

using constraints::ConstraintSet;
using imaging::read_node_list;
using imaging::read_skeleton_vtp;
using imaging::read_surface_vtp;
using imaging::read_tet_mesh;
using imaging::to_skeleton;
using nlohmann::json;

/// A JSON object being read: checks keys against a known list, types and ranges, and names the
/// file and the dotted key path in every error.
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
  void boolean(const std::string& k, bool& out) const {
    if (!has(k)) return;
    BS_VERIFY(m_j[k].is_boolean(), m_file << ": '" << name(k) << "' must be true or false");
    out = m_j[k].get<bool>();
  }
  [[nodiscard]] std::string text(const std::string& k,
                                 const std::set<std::string>& allowed = {}) const {
    BS_VERIFY(m_j[k].is_string(), m_file << ": '" << name(k) << "' must be a string");
    const std::string v = m_j[k].get<std::string>();
    if (!allowed.empty() && !allowed.count(v)) {
      std::string list;
      for (const auto& s : allowed) list += (list.empty() ? "" : "|") + s;
      BS_VERIFY(false, m_file << ": '" << name(k) << "' = \"" << v << "\" is not one of " << list);
    }
    return v;
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

void read_filter(const Reader& r, constraints::FilterOptions& f) {
  r.boolean("one_per_feature", f.one_per_feature);
  r.number("median_threshold_mm", f.median_threshold_mm, 0, kBig, "mm");
  r.number("min_distance_mm", f.min_distance_mm, 0, kBig, "mm");
  r.number("max_angle_deg", f.max_angle_deg, 0, 180, "deg");
  r.integer("max_per_tet", f.max_per_tet, 0, 1000);
}

const std::set<std::string> kFilterKeys = {"one_per_feature", "median_threshold_mm",
                                           "min_distance_mm", "max_angle_deg", "max_per_tet"};

void read_solver(const Reader& r, Scene& s) {
  auto& o = s.options;
  r.integer("max_iterations", o.max_iterations, 1, 100000);
  r.number("increment_tolerance_mm", o.increment_tolerance_mm, 1e-9, 100, "mm");
  r.number("trust_region_mm", o.step.max_increment, 0, 1000, "mm");
  r.number("pgs_tolerance", o.step.pgs.tolerance, 1e-14, 1, "");
  r.integer("pgs_max_iterations", o.step.pgs.max_iterations, 1, 1000000);
  if (r.has("constraint_solver")) {
    const std::string v = r.text("constraint_solver", {"auto", "active_set", "gauss_seidel"});
    o.step.solver = v == "auto"         ? constraints::ConstraintSolver::AUTO
                    : v == "active_set" ? constraints::ConstraintSolver::ACTIVE_SET
                                        : constraints::ConstraintSolver::GAUSS_SEIDEL;
  }
  if (r.has("mechanics")) {
    const std::string v = r.text("mechanics", {"warped", "unwarped", "linear", "exact"});
    o.step.mechanics = v == "warped"     ? constraints::Mechanics::WARPED
                       : v == "unwarped" ? constraints::Mechanics::UNWARPED
                       : v == "linear"   ? constraints::Mechanics::LINEAR
                                         : constraints::Mechanics::EXACT;
  }
  if (r.has("compliance")) {
    const Reader c = r.object("compliance", {"vessels", "footprint", "dura", "landmarks"});
    auto& ratio = o.step.compliance_ratio;
    c.number("vessels", ratio[static_cast<std::size_t>(ConstraintSet::VESSELS)], 0, 1000);
    c.number("footprint", ratio[static_cast<std::size_t>(ConstraintSet::FOOTPRINT)], 0, 1000);
    c.number("dura", ratio[static_cast<std::size_t>(ConstraintSet::DURA)], 0, 1000);
    c.number("landmarks", ratio[static_cast<std::size_t>(ConstraintSet::LANDMARK)], 0, 1000);
  }
  double budget_mib = static_cast<double>(s.compliance.memory_budget_bytes >> 20);
  r.number("compliance_budget_mib", budget_mib, 0, 1 << 20, "MiB");
  s.compliance.memory_budget_bytes = static_cast<std::size_t>(budget_mib * 1024 * 1024);
}

}  // namespace

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
    BS_VERIFY(false, file << ": not valid JSON (" << e.what() << ")");
  }
  const Reader r(j, file, "",
                 {"version", "mesh", "materials", "fixed", "collision_surface", "vessels",
                  "craniotomy", "constraints", "rigid", "pairing", "filter", "solver"});
  if (r.has("version")) {
    int version = 1;
    r.integer("version", version, 1, 1);
  }
  BS_VERIFY(r.has("mesh"), file << ": missing key 'mesh' (the tetrahedral mesh, .vtu)");
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
  Scene s;
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
  if (r.has("craniotomy")) {
    const Reader c = r.object("craniotomy", {"centre_mm", "radius_mm"});
    if (c.has("centre_mm")) o.dura.craniotomy_centre = c.vector3("centre_mm");
    c.number("radius_mm", o.dura.craniotomy_radius_mm, 0, 500, "mm");
  }
  if (r.has("constraints")) {
    const Reader c = r.object("constraints", {"vessels", "footprint", "dura", "landmarks"});
    c.boolean("vessels", o.use_vessels);
    c.boolean("footprint", o.use_footprint);
    c.boolean("landmarks", o.use_landmarks);
    if (c.has("dura")) {
      const std::string d = c.text("dura", {"none", "sliding", "unilateral"});
      o.dura.mode = d == "none"      ? constraints::DuraOptions::Mode::NONE
                    : d == "sliding" ? constraints::DuraOptions::Mode::SLIDING
                                     : constraints::DuraOptions::Mode::UNILATERAL;
    }
  }
  BS_VERIFY(o.dura.mode == constraints::DuraOptions::Mode::NONE || s.surface.triangles.rows() > 0,
            file << ": dura contact needs a 'collision_surface'");
  if (r.has("rigid")) {
    const Reader g =
        r.object("rigid", {"enabled", "loss", "loss_scale_mm", "max_pair_distance_mm"});
    bool enabled = o.start == constraints::RigidStart::RIGID;
    g.boolean("enabled", enabled);
    o.start = enabled ? constraints::RigidStart::RIGID : constraints::RigidStart::IDENTITY;
    if (g.has("loss")) {
      const std::string l = g.text("loss", {"huber", "cauchy", "none"});
      o.rigid.loss = l == "huber"    ? constraints::RigidInitOptions::Loss::HUBER
                     : l == "cauchy" ? constraints::RigidInitOptions::Loss::CAUCHY
                                     : constraints::RigidInitOptions::Loss::NONE;
    }
    g.number("loss_scale_mm", o.rigid.loss_scale_mm, 1e-6, 1000, "mm");
    g.number("max_pair_distance_mm", o.rigid.max_pair_distance_mm, 1e-6, 1000, "mm");
  }
  if (r.has("pairing")) {
    const Reader p = r.object("pairing", {"max_distance_mm", "direction_radius_mm"});
    p.number("max_distance_mm", o.pair_max_distance_mm, 1e-6, 1000, "mm");
    p.number("direction_radius_mm", o.direction_radius_mm, 1e-6, 1000, "mm");
  }
  if (r.has("filter")) {
    const Reader f = r.object("filter", {"vessels", "footprint"});
    if (f.has("vessels")) read_filter(f.object("vessels", kFilterKeys), o.vessel_filter);
    if (f.has("footprint")) read_filter(f.object("footprint", kFilterKeys), o.footprint_filter);
  }
  if (r.has("solver"))
    read_solver(r.object("solver", {"max_iterations", "increment_tolerance_mm", "trust_region_mm",
                                    "pgs_tolerance", "pgs_max_iterations", "constraint_solver",
                                    "mechanics", "compliance", "compliance_budget_mib"}),
                s);
  const std::string invalid = o.validate();
  BS_VERIFY(invalid.empty(), file << ": " << invalid);
  return s;
}

}  // namespace brainshift::workflow
