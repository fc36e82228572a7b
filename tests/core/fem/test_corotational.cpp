#include "random_rotation.hpp"
#include "tolerance.hpp"

#include "core/assembly/stiffness_assembly.hpp"
#include "core/error.hpp"
#include "core/fem/corotational.hpp"
#include "core/fem/rotation.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>
#include <string>

namespace brainshift::core {
namespace {

using tests::random_rotation;

Matrix3d axis_angle(double degrees, const Vector3d& axis) {
  return Eigen::AngleAxisd(degrees * M_PI / 180.0, axis.normalized()).toRotationMatrix();
}

/// Positions Q·x + t of every node (rows).
MatrixX3d transform(const MatrixX3d& x, const Matrix3d& Q, const Vector3d& t) {
  MatrixX3d y = (x * Q.transpose()).rowwise() + t.transpose();
  return y;
}

/// Q applied to each node's 3-vector of a node-major 3N vector.
Eigen::VectorXd rotate_nodal(const Eigen::VectorXd& f, const Matrix3d& Q) {
  Eigen::VectorXd out(f.size());
  for (Eigen::Index i = 0; i < f.size(); i += 3) out.segment<3>(i) = Q * f.segment<3>(i);
  return out;
}

Eigen::VectorXd force_at(const CorotationalModel& model, const MatrixX3d& x) {
  return model.internal_force(x, model.element_rotations(x).rotation);
}

/// Smooth non-affine displacement of amplitude `amplitude` (mm) over a body of size ~10 mm.
MatrixX3d smooth_displacement(const MatrixX3d& X, double amplitude) {
  MatrixX3d u(X.rows(), 3);
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    const double x = X(i, 0) / 10.0;
    const double y = X(i, 1) / 10.0;
    const double z = X(i, 2) / 10.0;
    u.row(i) << std::sin(x + 2 * y) * z, std::cos(y) * x * x - 0.3 * z, x * y * z + 0.5 * y;
  }
  return amplitude * u;
}

class CorotationalTest : public ::testing::Test {
 protected:
  TetMesh mesh = data_synth::make_box_mesh({10, 8, 12}, {3, 2, 4}, {-5, -4, -6});
  CorotationalModel model{mesh};
  SparseMatrix K0 = assemble_rest_stiffness(model);
};

TEST_F(CorotationalTest, RigidMotionsGiveZeroForce) {
  std::mt19937 rng(3);
  const Vector3d t(12.0, -7.0, 30.0);
  const std::vector<std::pair<std::string, Matrix3d>> rotations = {
      {"identity", Matrix3d::Identity()},
      {"90 deg about z", axis_angle(90, Vector3d::UnitZ())},
      {"90 deg about (1,1,0)", axis_angle(90, Vector3d(1, 1, 0))},
      {"180 deg about x", axis_angle(180, Vector3d::UnitX())},
      {"180 deg about (1,2,3)", axis_angle(180, Vector3d(1, 2, 3))},
      {"random", random_rotation(rng)},
  };
  for (const auto& [name, Q] : rotations) {
    SCOPED_TRACE(name);
    const MatrixX3d x = transform(mesh.nodes(), Q, t);
    const ElementRotations er = model.element_rotations(x);
    EXPECT_EQ(er.inverted_count, 0);
    const Eigen::VectorXd f = model.internal_force(x, er.rotation);
    // f = R K (Rᵀx − X): Rᵀx − X cancels to ~ε·‖x‖ per entry, times ‖K‖. 1e-13 ≈ 500 ε.
    EXPECT_LE(f.norm(), 1e-13 * K0.norm() * x.norm()) << "‖f‖ = " << f.norm();
  }
}

TEST_F(CorotationalTest, InternalForcesRotateWithTheBody) {
  std::mt19937 rng(5);
  const MatrixX3d x = mesh.nodes() + smooth_displacement(mesh.nodes(), 0.5);  // ~5 % strain
  const Eigen::VectorXd f = force_at(model, x);
  ASSERT_GT(f.norm(), 0.0);
  for (const Matrix3d& Q : {axis_angle(90, Vector3d::UnitY()), axis_angle(180, Vector3d(0, 1, 1)),
                            random_rotation(rng)}) {
    const Eigen::VectorXd fq = force_at(model, transform(x, Q, Vector3d(1, 2, 3)));
    // Exact equivariance; errors are rounding in R (SVD) and in R K Rᵀ x: 1e-12 relative.
    EXPECT_LE(tests::relative_difference(fq, rotate_nodal(f, Q)), 1e-12);
  }
}

TEST_F(CorotationalTest, EqualsLinearFemAtSmallStrain) {
  const double strain = 1e-6;
  // Scale the smooth field so that the largest element displacement gradient ‖∇u‖₂ is 1e-6.
  const MatrixX3d shape = smooth_displacement(mesh.nodes(), 1.0);
  double largest_gradient = 0.0;
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    Matrix3d G = Matrix3d::Zero();
    for (int k = 0; k < 4; ++k) {
      G += shape.row(mesh.tets()(t, k)).transpose() *
           model.shapes()[static_cast<std::size_t>(t)].grad.row(k);
    }
    largest_gradient = std::max(largest_gradient, G.norm());
  }
  const MatrixX3d u = (strain / largest_gradient) * shape;
  const MatrixX3d x = mesh.nodes() + u;
  const Eigen::VectorXd u_vec = Eigen::Map<const Eigen::VectorXd>(u.data(), u.size());
  const Eigen::VectorXd linear = K0 * u_vec;
  const double diff = tests::relative_difference(force_at(model, x), linear);
  // Corotational − linear is ([ω]K − K[ω])u to first order, with |ω| ≤ ‖skew ∇u‖ ≤ strain/√2
  // elementwise, plus cancellation in Rᵀx − X (ε‖X‖/‖u‖ ~ 1e-9): 1e-6 relative at 1e-6.
  EXPECT_LE(diff, 1e-6) << "measured " << diff;
  std::cout << "[ measured ] corotational vs linear force at 1e-6 strain: " << diff << "\n";
}

TEST_F(CorotationalTest, IdentityRotationsGiveTheAssembledLinearForce) {
  const MatrixX3d u = smooth_displacement(mesh.nodes(), 0.3);
  const std::vector<Matrix3d> identity(static_cast<std::size_t>(mesh.num_tets()),
                                       Matrix3d::Identity());
  const Eigen::VectorXd u_vec = Eigen::Map<const Eigen::VectorXd>(u.data(), u.size());
  // Same sums in another order, plus x − X cancellation (ε‖X‖/‖u‖ ≈ 1e-15·30): 1e-12.
  EXPECT_LE(
      tests::relative_difference(model.internal_force(mesh.nodes() + u, identity), K0 * u_vec),
      1e-12);
}

TEST_F(CorotationalTest, GravityForceSumsToTheWeight) {
  const Vector3d g(0, 0, -9810);
  const double rho = 1040e-9;
  const Eigen::VectorXd f = model.gravity_force(g, rho);
  Vector3d total = Vector3d::Zero();
  for (Eigen::Index i = 0; i < f.size(); i += 3) total += f.segment<3>(i);
  // Kuhn tets tile the 960 mm³ box exactly; only summation rounding remains.
  EXPECT_LE((total - rho * 960.0 * g).norm(), 1e-12 * (rho * 960.0 * g).norm());
}

TEST_F(CorotationalTest, InvertedElementsAreCountedWithProperRotations) {
  MatrixX3d x = mesh.nodes();
  x.row(0) = Vector3d(50, 50, 50).transpose();  // pulls node 0 through the opposite faces
  const ElementRotations er = model.element_rotations(x);
  EXPECT_GT(er.inverted_count, 0);
  for (const Matrix3d& R : er.rotation) {
    ASSERT_TRUE(R.allFinite());
    EXPECT_TRUE(tests::near(R.determinant(), 1.0, 1e-14, 0));  // SVD rounding only
  }
  EXPECT_TRUE(model.internal_force(x, er.rotation).allFinite());
}

TEST_F(CorotationalTest, NonFinitePositionThrowsNamingTheNode) {
  MatrixX3d x = mesh.nodes();
  x(17, 1) = std::numeric_limits<double>::quiet_NaN();
  try {
    (void)model.element_rotations(x);
    FAIL() << "NaN position accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("node 17"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)model.element_rotations(x.topRows(5)), Error);
}

TEST_F(CorotationalTest, APreStrainedRestIsStressFreeAndRotatesWithTheBody) {
  // The rest shape X + u (a 5 % strain field): there, and under any rigid motion of it, every
  // rotation is the motion's and the force is zero, although the mesh's rest would see 5 %
  // strain.
  std::mt19937 rng(11);
  const RestShape rest = model.rest_shape(mesh.nodes() + smooth_displacement(mesh.nodes(), 0.5));
  EXPECT_EQ(rest.degenerate, 0);
  for (const Matrix3d& Q :
       {Matrix3d::Identity().eval(), axis_angle(120, Vector3d(1, -1, 2)), random_rotation(rng)}) {
    const MatrixX3d x = transform(rest.nodes, Q, Vector3d(4, -2, 9));
    const ElementRotations er = model.element_rotations(x, &rest);
    EXPECT_EQ(er.inverted_count, 0);
    for (const Matrix3d& R : er.rotation) ASSERT_LE((R - Q).norm(), 1e-12);  // SVD rounding
    const Eigen::VectorXd f = model.internal_force(x, er.rotation, &rest);
    // As RigidMotionsGiveZeroForce: cancellation in Rᵀx − X', 1e-13 relative.
    EXPECT_LE(f.norm(), 1e-13 * K0.norm() * x.norm()) << "‖f‖ = " << f.norm();
    EXPECT_GT(force_at(model, x).norm(), 1e3 * f.norm());  // the mesh's rest is strained there
  }
}

TEST_F(CorotationalTest, APreStrainedRestSubtractsItsLinearForce) {
  // With the rotations held at the identity the force is linear: K0 (x − X − u) = K0 (x − X) −
  // K0 u, to rounding (an independent sum: the assembled K0).
  const MatrixX3d u = smooth_displacement(mesh.nodes(), 0.2);
  const RestShape rest = model.rest_shape(mesh.nodes() + u);
  const std::vector<Matrix3d> identity(static_cast<std::size_t>(mesh.num_tets()),
                                       Matrix3d::Identity());
  const MatrixX3d x = mesh.nodes() + smooth_displacement(mesh.nodes(), 0.35);
  const Eigen::VectorXd u_vec = Eigen::Map<const Eigen::VectorXd>(u.data(), u.size());
  const Eigen::VectorXd expected = model.internal_force(x, identity) - K0 * u_vec;
  EXPECT_LE(tests::relative_difference(model.internal_force(x, identity, &rest), expected), 1e-12);
}

TEST_F(CorotationalTest, AnInvertedElementOfAPreStrainedRestKeepsTheMeshsRest) {
  // A rest that turns some elements inside out cannot be their stress-free state: they keep the
  // mesh's rest (counted), the rest stay pre-strained, and everything stays finite.
  MatrixX3d y = mesh.nodes();
  y.row(0) = Vector3d(50, 50, 50).transpose();
  const RestShape rest = model.rest_shape(y);
  EXPECT_GT(rest.degenerate, 0);
  const ElementRotations er = model.element_rotations(y, &rest);
  const Eigen::VectorXd f = model.internal_force(y, er.rotation, &rest);
  ASSERT_TRUE(f.allFinite());
  // Node 0's elements are the degenerate ones; a node that touches none of them is in
  // equilibrium there.
  std::vector<bool> touches(static_cast<std::size_t>(mesh.num_nodes()), false);
  for (index_t t = 0; t < mesh.num_tets(); ++t)
    if (rest.mesh_rest[static_cast<std::size_t>(t)])
      for (int k = 0; k < 4; ++k) touches[static_cast<std::size_t>(mesh.tets()(t, k))] = true;
  EXPECT_TRUE(touches[0]);
  for (index_t i = 0; i < mesh.num_nodes(); ++i)
    if (!touches[static_cast<std::size_t>(i)]) {
      ASSERT_LE(f.segment<3>(3 * i).norm(), 1e-9 * f.norm());
    }
  EXPECT_THROW((void)model.rest_shape(y.topRows(4)), Error);
}

TEST(CorotationalModel, BadMeshesThrowNamingTheElementOrNode) {
  MatrixX3d X(5, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1;
  auto expect_named = [](const TetMesh& m, const std::string& what) {
    try {
      const CorotationalModel model(m);
      FAIL() << "accepted a mesh with " << what;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  MatrixX4i inverted(2, 4);
  inverted << 0, 1, 2, 3, 1, 3, 2, 4;  // second has negative volume
  expect_named(TetMesh(X, inverted), "tetrahedron 1");
  MatrixX3d flat = X;
  flat.row(4) << 0.5, 0.5, 0.0;  // midpoint of nodes 1 and 2: exactly coplanar with 1, 2, 3
  MatrixX4i tets(2, 4);
  tets << 0, 1, 2, 3, 1, 2, 3, 4;
  expect_named(TetMesh(flat, tets), "tetrahedron 1");
  MatrixX3d nan = X;
  nan(4, 2) = std::numeric_limits<double>::quiet_NaN();
  MatrixX4i good(2, 4);
  good << 0, 1, 2, 3, 1, 2, 3, 4;
  expect_named(TetMesh(nan, good), "node 4");
}

TEST(CorotationalThreads, BlocksOnThreadsGiveTheSerialElementLoopToTheBit) {
  // 12×10×12 cells × 6 Kuhn tets = 8,640 elements: more than one block of the threaded loops
  // (4,096), so the threads run. The reference is the plain serial element loop written here
  // (rotation per element, force summed in element order): the threaded code must give the same
  // bits, and count the same inverted elements.
  const TetMesh big = data_synth::make_box_mesh({24, 20, 24}, {12, 10, 12}, {-12, -10, -12});
  ASSERT_GT(big.num_tets(), 2 * 4096);
  const CorotationalModel model(big);
  MatrixX3d x = big.nodes() + smooth_displacement(big.nodes(), 2.0);
  x.row(7) += Vector3d(0, 0, 30).transpose();  // a few inverted elements as well
  const ElementRotations er = model.element_rotations(x);
  const MatrixX4i& T = big.tets();
  index_t inverted = 0;
  Eigen::VectorXd f_ref = Eigen::VectorXd::Zero(3 * big.num_nodes());
  for (index_t t = 0; t < big.num_tets(); ++t) {
    Matrix3d Ds;
    for (int k = 0; k < 3; ++k) Ds.col(k) = (x.row(T(t, k + 1)) - x.row(T(t, 0))).transpose();
    bool flipped = false;
    const Matrix3d R = rotation_from_deformation_gradient(
        Ds * model.shapes()[static_cast<std::size_t>(t)].rest_edges_inv, &flipped);
    inverted += flipped ? 1 : 0;
    ASSERT_EQ(R, er.rotation[static_cast<std::size_t>(t)]) << "element " << t;
    Vector12d d;
    for (int k = 0; k < 4; ++k)
      d.segment<3>(3 * k) =
          R.transpose() * x.row(T(t, k)).transpose() - big.nodes().row(T(t, k)).transpose();
    const Vector12d g = model.element_stiffness()[static_cast<std::size_t>(t)] * d;
    for (int k = 0; k < 4; ++k) {
      const Vector3d fk = R * g.segment<3>(3 * k);
      f_ref.segment<3>(3 * T(t, k)) += fk;
    }
  }
  EXPECT_GT(inverted, 0);
  EXPECT_EQ(er.inverted_count, inverted);
  const Eigen::VectorXd f = model.internal_force(x, er.rotation);
  EXPECT_EQ((f - f_ref).cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace brainshift::core
