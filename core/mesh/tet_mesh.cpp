#include "core/mesh/tet_mesh.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace brainshift::core {

TetMesh::TetMesh(MatrixX3d nodes, MatrixX4i tets, Eigen::VectorXd youngs_modulus,
                 Eigen::VectorXd poisson_ratio)
    : m_nodes(std::move(nodes)),
      m_tets(std::move(tets)),
      m_youngs_modulus(std::move(youngs_modulus)),
      m_poisson_ratio(std::move(poisson_ratio)) {
  if (m_youngs_modulus.size() == 0) {
    m_youngs_modulus = Eigen::VectorXd::Constant(m_tets.rows(), units::brain_youngs_modulus);
  }
  if (m_poisson_ratio.size() == 0) {
    m_poisson_ratio = Eigen::VectorXd::Constant(m_tets.rows(), units::default_poisson_ratio);
  }
  BS_VERIFY(m_youngs_modulus.size() == m_tets.rows(),
            "youngs_modulus has " << m_youngs_modulus.size() << " values for " << m_tets.rows()
                                  << " tetrahedra");
  BS_VERIFY(m_poisson_ratio.size() == m_tets.rows(), "poisson_ratio has "
                                                         << m_poisson_ratio.size() << " values for "
                                                         << m_tets.rows() << " tetrahedra");
}

Eigen::Matrix<double, 4, 3> TetMesh::tet_nodes(index_t t) const {
  Eigen::Matrix<double, 4, 3> X;
  for (int k = 0; k < 4; ++k) X.row(k) = m_nodes.row(m_tets(t, k));
  return X;
}

double TetMesh::signed_volume(index_t t) const {
  return signed_tet_volume(m_nodes.row(m_tets(t, 0)), m_nodes.row(m_tets(t, 1)),
                           m_nodes.row(m_tets(t, 2)), m_nodes.row(m_tets(t, 3)));
}

double signed_tet_volume(const Vector3d& a, const Vector3d& b, const Vector3d& c,
                         const Vector3d& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

std::string to_string(MeshIssue::Kind kind) {
  switch (kind) {
    case MeshIssue::Kind::NAN_COORDINATE:
      return "NaN coordinate";
    case MeshIssue::Kind::INDEX_OUT_OF_RANGE:
      return "index out of range";
    case MeshIssue::Kind::REPEATED_NODE:
      return "repeated node";
    case MeshIssue::Kind::NON_POSITIVE_VOLUME:
      return "non-positive volume";
    case MeshIssue::Kind::UNUSED_NODE:
      return "unused node";
    case MeshIssue::Kind::BAD_MATERIAL:
      return "bad material";
  }
  BS_UNREACHABLE();
}

std::vector<MeshIssue> find_mesh_issues(const TetMesh& mesh, std::size_t max_issues) {
  std::vector<MeshIssue> issues;
  auto add = [&](MeshIssue::Kind kind, index_t index, std::string message) {
    if (issues.size() < max_issues) issues.push_back({kind, index, std::move(message)});
  };
  const index_t n = mesh.num_nodes();
  const auto& X = mesh.nodes();
  const auto& T = mesh.tets();
  if (n == 0) add(MeshIssue::Kind::UNUSED_NODE, -1, "mesh has no nodes");
  if (mesh.num_tets() == 0) add(MeshIssue::Kind::NON_POSITIVE_VOLUME, -1, "mesh has no tetrahedra");

  for (index_t i = 0; i < n; ++i) {
    if (!X.row(i).allFinite()) {
      std::ostringstream s;
      s << "node " << i << " has a non-finite coordinate (" << X(i, 0) << ", " << X(i, 1) << ", "
        << X(i, 2) << ")";
      add(MeshIssue::Kind::NAN_COORDINATE, i, s.str());
    }
  }
  std::vector<char> used(static_cast<std::size_t>(n), 0);
  std::vector<char> indices_ok(static_cast<std::size_t>(mesh.num_tets()), 1);
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    for (int k = 0; k < 4; ++k) {
      const index_t v = T(t, k);
      if (v < 0 || v >= n) {
        std::ostringstream s;
        s << "tetrahedron " << t << " refers to node " << v << ", outside [0, " << n << ")";
        add(MeshIssue::Kind::INDEX_OUT_OF_RANGE, t, s.str());
        indices_ok[t] = 0;
      } else {
        used[v] = 1;
      }
    }
    if (indices_ok[t]) {
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b)
          if (T(t, a) == T(t, b)) {
            std::ostringstream s;
            s << "tetrahedron " << t << " uses node " << T(t, a) << " twice";
            add(MeshIssue::Kind::REPEATED_NODE, t, s.str());
            indices_ok[t] = 0;
          }
    }
  }
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    if (!indices_ok[t]) continue;
    const double v = mesh.signed_volume(t);
    if (std::isfinite(v) && v <= 0.0) {
      std::ostringstream s;
      s << "tetrahedron " << t << " (nodes " << T(t, 0) << " " << T(t, 1) << " " << T(t, 2) << " "
        << T(t, 3) << ") has non-positive volume " << v << " mm^3"
        << (v < 0 ? " (inverted: swap two nodes)" : " (degenerate)");
      add(MeshIssue::Kind::NON_POSITIVE_VOLUME, t, s.str());
    }
  }
  for (index_t i = 0; i < n; ++i) {
    if (!used[i]) {
      std::ostringstream s;
      s << "node " << i
        << " is used by no tetrahedron (remove it: it makes the stiffness singular)";
      add(MeshIssue::Kind::UNUSED_NODE, i, s.str());
    }
  }
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    const double E = mesh.youngs_modulus()(t);
    const double nu = mesh.poisson_ratio()(t);
    if (!(E > 0.0) || !std::isfinite(E) || !(nu > -1.0 && nu < 0.5)) {
      std::ostringstream s;
      s << "tetrahedron " << t << " has Young's modulus " << E << " kPa and Poisson ratio " << nu
        << " (need E > 0 and -1 < nu < 0.5)";
      add(MeshIssue::Kind::BAD_MATERIAL, t, s.str());
    }
  }
  return issues;
}

void validate(const TetMesh& mesh, const std::string& what) {
  const auto issues = find_mesh_issues(mesh, 1000);
  if (issues.empty()) return;
  std::ostringstream s;
  s << what << ": " << to_string(issues.front().kind) << ": " << issues.front().message;
  if (issues.size() > 1)
    s << " (and " << issues.size() - 1 << (issues.size() >= 1000 ? "+" : "") << " more problems)";
  throw Error(s.str());
}

std::array<double, 6> dihedral_angles_deg(const Eigen::Matrix<double, 4, 3>& X) {
  // Face k is opposite node k; its outward normal n_k. The dihedral angle at the edge shared
  // by faces i and j is pi - angle(n_i, n_j).
  std::array<Vector3d, 4> normal;
  for (int k = 0; k < 4; ++k) {
    const int a = (k + 1) % 4, b = (k + 2) % 4, c = (k + 3) % 4;
    Vector3d nrm = (X.row(b) - X.row(a)).transpose().cross((X.row(c) - X.row(a)).transpose());
    if ((X.row(k) - X.row(a)).dot(nrm.transpose()) > 0) nrm = -nrm;  // point away from node k
    const double len = nrm.norm();
    normal[k] = len > 0 ? Vector3d(nrm / len) : Vector3d::Zero();
  }
  std::array<double, 6> angles{};
  int e = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) {
      const double c = std::clamp(normal[i].dot(normal[j]), -1.0, 1.0);
      angles[e++] = 180.0 - std::acos(c) * 180.0 / std::numbers::pi;
    }
  return angles;
}

QualityReport quality_report(const TetMesh& mesh, double sliver_threshold_deg) {
  QualityReport r;
  r.num_tets = mesh.num_tets();
  r.sliver_threshold_deg = sliver_threshold_deg;
  if (r.num_tets == 0) return r;
  r.min_volume = std::numeric_limits<double>::infinity();
  r.max_volume = -std::numeric_limits<double>::infinity();
  r.min_dihedral_deg = 180.0;
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    const double v = mesh.signed_volume(t);
    r.min_volume = std::min(r.min_volume, v);
    r.max_volume = std::max(r.max_volume, v);
    const auto a = dihedral_angles_deg(mesh.tet_nodes(t));
    const double lo = *std::min_element(a.begin(), a.end());
    const double hi = *std::max_element(a.begin(), a.end());
    if (lo < r.min_dihedral_deg) {
      r.min_dihedral_deg = lo;
      r.worst_tet = t;
    }
    r.max_dihedral_deg = std::max(r.max_dihedral_deg, hi);
    if (lo < sliver_threshold_deg || hi > 180.0 - sliver_threshold_deg) ++r.sliver_count;
  }
  return r;
}

}  // namespace brainshift::core
