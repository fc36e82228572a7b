#include "core/fem/corotational.hpp"

#include "core/error.hpp"
#include "core/fem/rotation.hpp"
#include "core/parallel.hpp"

#include <cmath>

namespace brainshift::core {

namespace {

/// Elements per block of the per-element loops, which run on up to kThreads threads: each block
/// writes only its own elements, so the results are the same on any number of threads (the
/// nodal sums stay serial, in element order). Below two blocks nothing is started.
constexpr std::size_t kElementBlock = 4096;
constexpr int kThreads = 2;

/// The 12-vector (x0, y0, z0, …, z3) of the nodes of tetrahedron t in positions P (#N×3).
Vector12d gather(ConstRef<MatrixX3d> P, const MatrixX4i& T, index_t t) {
  Vector12d v;
  for (int k = 0; k < 4; ++k) v.segment<3>(3 * k) = P.row(T(t, k)).transpose();
  return v;
}

}  // namespace

CorotationalModel::CorotationalModel(const TetMesh& mesh) : m_mesh(mesh) {
  validate(m_mesh, "corotational model mesh");
  const index_t nt = m_mesh.num_tets();
  m_shapes.reserve(static_cast<std::size_t>(nt));
  m_stiffness.reserve(static_cast<std::size_t>(nt));
  for (index_t t = 0; t < nt; ++t) {
    try {
      m_shapes.push_back(tet_shape(m_mesh.tet_nodes(t)));
      m_stiffness.push_back(linear_tet_stiffness(m_shapes.back(), m_mesh.youngs_modulus()(t),
                                                 m_mesh.poisson_ratio()(t)));
    } catch (const Error& e) {
      BS_THROW("tetrahedron " << t << ": " << e.what());
    }
  }
}

ElementRotations CorotationalModel::element_rotations(ConstRef<MatrixX3d> x,
                                                      const RestShape* rest) const {
  const index_t n = m_mesh.num_nodes();
  BS_VERIFY(x.rows() == n, "positions have " << x.rows() << " rows, expected " << n << " nodes");
  for (index_t i = 0; i < n; ++i) {
    BS_VERIFY(x.row(i).allFinite(), "node " << i << " has a non-finite position (" << x(i, 0)
                                            << ", " << x(i, 1) << ", " << x(i, 2) << ")");
  }
  BS_VERIFY(!rest || (rest->nodes.rows() == n &&
                      rest->edges_inv.size() == static_cast<std::size_t>(m_mesh.num_tets())),
            "the rest shape is not of this mesh");
  const MatrixX4i& T = m_mesh.tets();
  ElementRotations out;
  out.rotation.resize(static_cast<std::size_t>(m_mesh.num_tets()));
  std::vector<std::uint8_t> inverted(out.rotation.size(), 0);
  parallel_blocks(
      out.rotation.size(), kElementBlock, kThreads, [&](std::size_t begin, std::size_t end) {
        for (std::size_t ut = begin; ut < end; ++ut) {
          const auto t = static_cast<index_t>(ut);
          Matrix3d Ds;
          for (int k = 0; k < 3; ++k) Ds.col(k) = (x.row(T(t, k + 1)) - x.row(T(t, 0))).transpose();
          const Matrix3d F = Ds * (rest ? rest->edges_inv[ut] : m_shapes[ut].rest_edges_inv);
          bool flipped = false;
          out.rotation[ut] = rotation_from_deformation_gradient(F, &flipped);
          inverted[ut] = flipped ? 1 : 0;
        }
      });
  for (const std::uint8_t v : inverted) out.inverted_count += v;
  return out;
}

Eigen::VectorXd CorotationalModel::internal_force(ConstRef<MatrixX3d> x,
                                                  const std::vector<Matrix3d>& rotations,
                                                  const RestShape* rest) const {
  const index_t n = m_mesh.num_nodes();
  const index_t nt = m_mesh.num_tets();
  BS_VERIFY(x.rows() == n, "positions have " << x.rows() << " rows, expected " << n << " nodes");
  BS_VERIFY(static_cast<index_t>(rotations.size()) == nt,
            "got " << rotations.size() << " element rotations, expected " << nt);
  BS_VERIFY(
      !rest || (rest->nodes.rows() == n && rest->mesh_rest.size() == static_cast<std::size_t>(nt)),
      "the rest shape is not of this mesh");
  const MatrixX4i& T = m_mesh.tets();
  // Each element's nodal forces R̂ K_e (R̂ᵀ x_e − X_e), on threads; then summed into the nodes
  // in element order (serial: the same sums, to the bit, on any number of threads).
  std::vector<Vector12d> element_force(static_cast<std::size_t>(nt));
  parallel_blocks(
      element_force.size(), kElementBlock, kThreads, [&](std::size_t begin, std::size_t end) {
        for (std::size_t ut = begin; ut < end; ++ut) {
          const auto t = static_cast<index_t>(ut);
          const Matrix3d& R = rotations[ut];
          const Vector12d xe = gather(x, T, t);
          const bool own = rest && !rest->mesh_rest[ut];
          const Vector12d Xe = gather(own ? rest->nodes : m_mesh.nodes(), T, t);
          Vector12d d;  // R̂ᵀ x_e − X_e
          for (int k = 0; k < 4; ++k)
            d.segment<3>(3 * k) = R.transpose() * xe.segment<3>(3 * k) - Xe.segment<3>(3 * k);
          const Vector12d g = m_stiffness[ut] * d;
          for (int k = 0; k < 4; ++k) element_force[ut].segment<3>(3 * k) = R * g.segment<3>(3 * k);
        }
      });
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * n);
  for (index_t t = 0; t < nt; ++t)
    for (int k = 0; k < 4; ++k)
      f.segment<3>(3 * T(t, k)) += element_force[static_cast<std::size_t>(t)].segment<3>(3 * k);
  return f;
}

RestShape CorotationalModel::rest_shape(ConstRef<MatrixX3d> nodes) const {
  const index_t n = m_mesh.num_nodes();
  BS_VERIFY(nodes.rows() == n, "rest shape has " << nodes.rows() << " rows, expected " << n);
  BS_VERIFY(nodes.allFinite(), "rest shape has a non-finite node");
  const MatrixX4i& T = m_mesh.tets();
  RestShape rest;
  rest.nodes = nodes;
  rest.edges_inv.resize(static_cast<std::size_t>(m_mesh.num_tets()));
  rest.mesh_rest.assign(static_cast<std::size_t>(m_mesh.num_tets()), 0);
  for (index_t t = 0; t < m_mesh.num_tets(); ++t) {
    const auto ut = static_cast<std::size_t>(t);
    Matrix3d Dm;
    for (int k = 0; k < 3; ++k)
      Dm.col(k) = (nodes.row(T(t, k + 1)) - nodes.row(T(t, 0))).transpose();
    // det Dm / 6 is the signed volume; the mesh's is positive (validated).
    if (Dm.determinant() / 6.0 >= 1e-3 * m_shapes[ut].volume) {
      rest.edges_inv[ut] = Dm.inverse();
    } else {
      rest.edges_inv[ut] = m_shapes[ut].rest_edges_inv;
      rest.mesh_rest[ut] = 1;
      ++rest.degenerate;
    }
  }
  return rest;
}

Eigen::VectorXd CorotationalModel::gravity_force(const Vector3d& gravity, double density) const {
  BS_VERIFY(gravity.allFinite(), "gravity is not finite: " << gravity.transpose());
  BS_VERIFY(std::isfinite(density) && density >= 0.0,
            "density must be finite and non-negative, got " << density << " kg/mm³");
  const MatrixX4i& T = m_mesh.tets();
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * m_mesh.num_nodes());
  for (index_t t = 0; t < m_mesh.num_tets(); ++t) {
    const Vector3d quarter =
        0.25 * density * m_shapes[static_cast<std::size_t>(t)].volume * gravity;
    for (int k = 0; k < 4; ++k) f.segment<3>(3 * T(t, k)) += quarter;
  }
  return f;
}

}  // namespace brainshift::core
