// The predicted-error model (issue 16): the nodal posterior traces against a dense closed-form
// computation on a small model, its limits (no data → the prior; many exact observations of a
// node → ≈ 0 there), the coarse prior against the exact one, and on a registration: a handful
// of vessel points predicts a larger error than the full set, far from the vessels more than near.
#include "tests/constraints/registration/sag_scene.hpp"

#include "constraints/registration/registration_model.hpp"
#include "constraints/registration/uncertainty/uncertainty.hpp"
#include "core/error.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

namespace brainshift::constraints {
namespace {

/// A 20 × 20 × 40 mm box (5 × 5 × 9 nodes) fixed at its base: small enough for dense K⁻¹.
struct Box {
  core::TetMesh mesh = data_synth::make_box_mesh({20, 20, 40}, {4, 4, 8});
  std::unique_ptr<ConstrainedModel> model;
  Box() {
    std::vector<index_t> fixed;
    for (index_t i = 0; i < mesh.num_nodes(); ++i)
      if (mesh.nodes()(i, 2) < mesh.nodes().col(2).minCoeff() + 1e-9) fixed.push_back(i);
    model = std::make_unique<ConstrainedModel>(mesh, fixed, std::vector<index_t>{});
  }
  [[nodiscard]] index_t free_dofs() const { return model->dofs().num_free(); }
};

/// Dense reference: per-node traces of K⁻¹ − K⁻¹G (GᵀK⁻¹G + diag a)⁻¹ GᵀK⁻¹ (0 on fixed nodes).
std::pair<Eigen::VectorXd, Eigen::VectorXd> dense_traces(const Box& b, const Eigen::MatrixXd& G,
                                                         const Eigen::VectorXd& a) {
  const Eigen::MatrixXd K = Eigen::MatrixXd(b.model->dofs().restrict(b.model->rest_stiffness()));
  const Eigen::MatrixXd Kinv = K.inverse();
  Eigen::MatrixXd P = Kinv;
  if (G.cols() > 0) {
    Eigen::MatrixXd S = G.transpose() * Kinv * G;
    S.diagonal() += a;
    P -= Kinv * G * S.inverse() * G.transpose() * Kinv;
  }
  const index_t n = b.mesh.num_nodes();
  Eigen::VectorXd prior = Eigen::VectorXd::Zero(n), post = Eigen::VectorXd::Zero(n);
  for (index_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      if (const index_t f = b.model->dofs().free_index(3 * i + c); f >= 0) {
        prior[i] += Kinv(f, f);
        post[i] += P(f, f);
      }
  return {prior, post};
}

/// `rows` random scalar observations of random top-half nodes, as a sparse #free × rows G.
SparseMatrix random_rows(const Box& b, int rows, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<index_t> node(0, b.mesh.num_nodes() - 1);
  std::normal_distribution<double> g;
  std::vector<Eigen::Triplet<double>> t;
  for (int j = 0; j < rows; ++j) {
    index_t n;
    do n = node(rng);
    while (b.model->dofs().is_fixed_node(n));
    const Vector3d d = Vector3d(g(rng), g(rng), g(rng)).normalized();
    for (int c = 0; c < 3; ++c) t.emplace_back(b.model->dofs().free_index(3 * n + c), j, d[c]);
  }
  SparseMatrix G(b.free_dofs(), rows);
  G.setFromTriplets(t.begin(), t.end());
  return G;
}

UncertaintyOptions exact_prior() {
  UncertaintyOptions o;
  o.coarse_spacing_mm = 0.0;
  o.solve_block = 17;  // several blocks, one of them partial
  return o;
}

TEST(Uncertainty, NodalTracesMatchTheDenseClosedForm) {
  const Box b;
  const SparseMatrix G = random_rows(b, 30, 7);
  Eigen::VectorXd a(30);
  for (int j = 0; j < 30; ++j) a[j] = 1e-4 * (1 + j % 3);  // mm/mN, of the order of diag W here
  const NodalVariance nv =
      nodal_variance(b.model->factor(), b.model->dofs(), b.mesh.nodes(), G, a, exact_prior());
  const auto [prior, post] = dense_traces(b, Eigen::MatrixXd(G), a);
  // Same algebra in another order (dense inverse vs Cholesky solves): agreement to round-off,
  // 1e-8 relative to the largest prior trace.
  const double tol = 1e-8 * prior.maxCoeff();
  for (index_t i = 0; i < b.mesh.num_nodes(); ++i) {
    EXPECT_NEAR(nv.prior[i], prior[i], tol) << "node " << i;
    EXPECT_NEAR(nv.posterior[i], post[i], tol) << "node " << i;
  }
  EXPECT_EQ(nv.exact_nodes, b.mesh.num_nodes() - 25);  // every free node; 25 fixed at the base
  // The data reduce the variance somewhere, and nowhere increase it.
  EXPECT_LT(nv.posterior.sum(), 0.95 * nv.prior.sum());
  EXPECT_TRUE(((nv.prior - nv.posterior).array() >= -tol).all());
}

TEST(Uncertainty, WithoutDataThePosteriorIsThePriorAndFixedNodesHaveNone) {
  const Box b;
  const NodalVariance nv =
      nodal_variance(b.model->factor(), b.model->dofs(), b.mesh.nodes(),
                     SparseMatrix(b.free_dofs(), 0), Eigen::VectorXd(), exact_prior());
  EXPECT_EQ((nv.posterior - nv.prior).cwiseAbs().maxCoeff(),
            0.0);  // nothing subtracted: exactly equal
  for (index_t i = 0; i < b.mesh.num_nodes(); ++i)
    if (b.model->dofs().is_fixed_node(i)) {
      EXPECT_EQ(nv.prior[i], 0.0) << "fixed node " << i;
    } else {
      EXPECT_GT(nv.prior[i], 0.0) << "free node " << i;
    }
}

TEST(Uncertainty, ManyExactObservationsOfANodeLeaveAlmostNoVarianceThere) {
  const Box b;
  const index_t top = b.mesh.num_nodes() - 1;  // a corner of the top face (farthest from the base)
  // 10 repeated observations of each of its 3 DOFs with a tiny noise (1e-6 of its prior variance).
  std::vector<Eigen::Triplet<double>> t;
  for (int r = 0; r < 10; ++r)
    for (int c = 0; c < 3; ++c)
      t.emplace_back(b.model->dofs().free_index(3 * top + c), 3 * r + c, 1.0);
  SparseMatrix G(b.free_dofs(), 30);
  G.setFromTriplets(t.begin(), t.end());
  const NodalVariance p0 =
      nodal_variance(b.model->factor(), b.model->dofs(), b.mesh.nodes(),
                     SparseMatrix(b.free_dofs(), 0), Eigen::VectorXd(), exact_prior());
  const Eigen::VectorXd a = Eigen::VectorXd::Constant(30, 1e-6 * p0.prior[top] / 3);
  const NodalVariance nv =
      nodal_variance(b.model->factor(), b.model->dofs(), b.mesh.nodes(), G, a, exact_prior());
  // Posterior ≈ noise / 10 per DOF ≈ 1e-7 of the prior; asked < 1e-5 (round-off of the
  // subtraction).
  EXPECT_LT(nv.posterior[top], 1e-5 * nv.prior[top]);
  // A node at the base's level keeps most of its (small) variance: it is not tied to the corner.
  index_t low = -1;
  for (index_t i = 0; i < b.mesh.num_nodes() && low < 0; ++i)
    if (!b.model->dofs().is_fixed_node(i) &&
        b.mesh.nodes()(i, 2) < b.mesh.nodes().col(2).minCoeff() + 6)
      low = i;
  ASSERT_GE(low, 0);
  EXPECT_GT(nv.posterior[low], 0.5 * nv.prior[low]);
}

TEST(Uncertainty, CoarsePriorIsCloseToTheExactOne) {
  const Scene scene;  // the 10 mm ellipsoid: ≈ 1,000 nodes, prior smooth away from the base
  const ConstrainedModel& m = scene.model->mechanics();
  const SparseMatrix none(m.dofs().num_free(), 0);
  const NodalVariance exact = nodal_variance(m.factor(), m.dofs(), scene.mesh.nodes(), none,
                                             Eigen::VectorXd(), exact_prior());
  UncertaintyOptions coarse;
  coarse.coarse_spacing_mm = 15.0;
  const NodalVariance c =
      nodal_variance(m.factor(), m.dofs(), scene.mesh.nodes(), none, Eigen::VectorXd(), coarse);
  EXPECT_LT(c.exact_nodes, exact.exact_nodes / 3);  // really coarse
  std::vector<double> rel;
  for (index_t i = 0; i < scene.mesh.num_nodes(); ++i)
    if (exact.prior[i] > 0) rel.push_back(std::abs(std::sqrt(c.prior[i] / exact.prior[i]) - 1.0));
  std::sort(rel.begin(), rel.end());
  std::printf(
      "coarse prior: %lld of %lld nodes exact; relative error median %.3f, p90 %.3f, max %.3f\n",
      static_cast<long long>(c.exact_nodes), static_cast<long long>(exact.exact_nodes),
      rel[rel.size() / 2], rel[rel.size() * 9 / 10], rel.back());
  // The predicted error (sqrt of the trace) from the interpolated prior: median within 10 %,
  // 90th percentile within 25 % (measured: see the failure message); worst near the fixed base,
  // where the prior drops to 0 over one element.
  EXPECT_LT(rel[rel.size() / 2], 0.10) << "median relative error";
  EXPECT_LT(rel[rel.size() * 9 / 10], 0.25) << "p90 relative error";
}

TEST(Uncertainty, AHandfulOfVesselPointsPredictsALargerErrorThanTheFullSet) {
  const Scene scene;
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;  // the loop from the tracked frame (the scene's own frame)
  IntraopData all;
  all.vessel_points = sample_deformed(scene.skeleton, 0.3, 11);
  IntraopData few;
  few.vessel_points = all.vessel_points.topRows(6);
  const RegistrationResult r_all = register_model(*scene.model, all, o);
  const RegistrationResult r_few = register_model(*scene.model, few, o);
  const UncertaintyResult u_all = predict_uncertainty(*scene.model, r_all, o);
  const UncertaintyResult u_few = predict_uncertainty(*scene.model, r_few, o);
  std::printf("all %lld pts: %s, %.3f s\nfew: %s\n",
              static_cast<long long>(all.vessel_points.rows()), u_all.estimation.c_str(),
              u_all.seconds, u_few.estimation.c_str());
  ASSERT_TRUE(u_all.estimated) << u_all.estimation;
  ASSERT_TRUE(u_all.node_sigma_mm.allFinite());
  ASSERT_TRUE(u_few.node_sigma_mm.allFinite());
  auto median = [&](const Eigen::VectorXd& v) {
    std::vector<double> x;
    for (index_t i = 0; i < v.size(); ++i)
      if (!scene.model->mechanics().dofs().is_fixed_node(i)) x.push_back(v[i]);
    std::nth_element(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(x.size() / 2), x.end());
    return x[x.size() / 2];
  };
  // Six points on one branch cannot tell the sag of the other five: the map must say so
  // (asked: a median predicted error at least 1.5 × that of the 180 points).
  EXPECT_GT(median(u_few.node_sigma_mm), 1.5 * median(u_all.node_sigma_mm))
      << u_few.estimation << " | " << u_all.estimation;
  // Near the vessels (their skeleton points) the full set predicts less than far from them.
  const Eigen::VectorXd at_vessels =
      sigma_at(scene.mesh, u_all.node_variance, scene.skeleton.points);
  MatrixX3d deep(1, 3);
  deep << 0.0, 0.0, -12.0;  // 10 mm below the lowest vessel, 10 mm above the fixed base
  EXPECT_LT(at_vessels.mean(), sigma_at(scene.mesh, u_all.node_variance, deep)[0] * 2.0);
  // Fixed nodes: no deformable variance (their pose is uncertain: the rigid term only).
  for (index_t i = 0; i < scene.mesh.num_nodes(); ++i)
    if (scene.model->mechanics().dofs().is_fixed_node(i)) {
      EXPECT_EQ(u_all.node_posterior[i], 0.0);
    }
}

/// Rows observing random directions d_j at random free nodes, in the world frame of nodes that
/// carry random rotations R_n: G = (H R)ᵀ on the free DOFs and each row's rigid sensitivity
/// [d_j, (x_j − c) × d_j]; plus the row's node.
struct RotatedRows {
  SparseMatrix G;
  Eigen::MatrixXd Gr;
  std::vector<index_t> node;
  std::vector<Vector3d> dir;
  std::vector<Matrix3d> R;
  Vector3d centre{3.0, -2.0, 25.0};
};

RotatedRows rotated_rows(const Box& b, int rows, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<index_t> pick(0, b.mesh.num_nodes() - 1);
  std::normal_distribution<double> g;
  RotatedRows out;
  for (index_t i = 0; i < b.mesh.num_nodes(); ++i)
    out.R.push_back(Eigen::AngleAxisd(0.3 * g(rng), Vector3d(g(rng), g(rng), g(rng)).normalized())
                        .toRotationMatrix());
  std::vector<Eigen::Triplet<double>> t;
  out.Gr.resize(rows, 6);
  for (int j = 0; j < rows; ++j) {
    index_t n;
    do n = pick(rng);
    while (b.model->dofs().is_fixed_node(n));
    const Vector3d d = Vector3d(g(rng), g(rng), g(rng)).normalized();
    const Vector3d gd = out.R[std::size_t(n)].transpose() * d;
    for (int c = 0; c < 3; ++c) t.emplace_back(b.model->dofs().free_index(3 * n + c), j, gd[c]);
    out.Gr.row(j).head<3>() = d.transpose();
    out.Gr.row(j).tail<3>() = (b.mesh.nodes().row(n).transpose() - out.centre).cross(d).transpose();
    out.node.push_back(n);
    out.dir.push_back(d);
  }
  out.G = SparseMatrix(b.free_dofs(), rows);
  out.G.setFromTriplets(t.begin(), t.end());
  return out;
}

/// Dense reference of the rigid pose as an unknown: z = [u_free; θ] with covariance
/// blkdiag(K⁻¹, λ I) and λ large (the flat prior's limit), the world displacement of node n
/// R_n u_n + h_n θ, conditioned on the rows y = B z + e, e ~ N(0, diag a). Returns the world
/// nodal traces and the rows' marginal covariance B Cz Bᵀ + diag a.
std::pair<Eigen::VectorXd, Eigen::MatrixXd> dense_rigid(const Box& b, const RotatedRows& rr,
                                                        const Eigen::VectorXd& a, double lambda) {
  const Eigen::MatrixXd K = Eigen::MatrixXd(b.model->dofs().restrict(b.model->rest_stiffness()));
  const index_t f = K.rows(), m = rr.Gr.rows(), n = b.mesh.num_nodes();
  Eigen::MatrixXd Cz = Eigen::MatrixXd::Zero(f + 6, f + 6);
  Cz.topLeftCorner(f, f) = K.inverse();
  Cz.bottomRightCorner(6, 6) = lambda * Eigen::MatrixXd::Identity(6, 6);
  Eigen::MatrixXd B(m, f + 6);
  B.leftCols(f) = Eigen::MatrixXd(rr.G).transpose();
  B.rightCols(6) = rr.Gr;
  Eigen::MatrixXd S = B * Cz * B.transpose();
  S.diagonal() += a;
  const Eigen::MatrixXd Pz = Cz - Cz * B.transpose() * S.ldlt().solve(B * Cz);
  Eigen::VectorXd tr = Eigen::VectorXd::Zero(n);
  for (index_t i = 0; i < n; ++i) {
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(3, f + 6);
    for (int c = 0; c < 3; ++c)
      if (const index_t fi = b.model->dofs().free_index(3 * i + c); fi >= 0)
        T.block(0, fi, 3, 1) = rr.R[std::size_t(i)].col(c);
    T.block<3, 3>(0, f).setIdentity();
    const Vector3d x = b.mesh.nodes().row(i).transpose() - rr.centre;
    Matrix3d cx;
    cx << 0, -x.z(), x.y(), x.z(), 0, -x.x(), -x.y(), x.x(), 0;
    T.block<3, 3>(0, f + 3) = -cx;
    tr[i] = (T * Pz * T.transpose()).trace();
  }
  return {tr, S};
}

TEST(Uncertainty, RigidTermMatchesADenseAugmentedModelWithAFlatPosePrior) {
  const Box b;
  const RotatedRows rr = rotated_rows(b, 40, 3);
  const Eigen::VectorXd a = Eigen::VectorXd::Constant(40, 2e-4);
  NodalVarianceExtras ex;
  ex.rigid_rows = &rr.Gr;
  const MatrixX3d x = b.mesh.nodes();
  ex.rigid_points = &x;
  ex.rigid_centre = rr.centre;
  ex.node_rotations = &rr.R;
  const NodalVariance nv = nodal_variance(b.model->factor(), b.model->dofs(), b.mesh.nodes(), rr.G,
                                          a, exact_prior(), ex);
  EXPECT_EQ(nv.rigid_rank, 6);  // 40 rows in random directions determine the pose
  // λ = 1e5 × the largest prior trace: the flat prior's limit to O(1e-5) relative, well above
  // the dense solve's round-off (≈ 1e-16 × λ / prior ≈ 1e-11).
  const double lambda = 1e5 * nv.prior.maxCoeff();
  const Eigen::VectorXd ref = dense_rigid(b, rr, a, lambda).first;
  const Eigen::VectorXd ours = nv.posterior + nv.rigid;
  const double tol = 1e-4 * ref.maxCoeff();
  for (index_t i = 0; i < b.mesh.num_nodes(); ++i)
    EXPECT_NEAR(ours[i], ref[i], tol) << "node " << i;
  // The fixed nodes move with the pose: their variance is the rigid term alone, and positive.
  for (index_t i = 0; i < b.mesh.num_nodes(); ++i)
    if (b.model->dofs().is_fixed_node(i)) {
      EXPECT_EQ(nv.posterior[i], 0.0);
      EXPECT_GT(nv.rigid[i], 0.0);
    }
}

TEST(Uncertainty, HeldOutAndRestrictedScalesMatchDenseRefits) {
  const Box b;
  const RotatedRows rr = rotated_rows(b, 36, 5);
  const Eigen::VectorXd a = Eigen::VectorXd::Constant(36, 3e-4);
  std::vector<index_t> blocks(36);
  for (int j = 0; j < 36; ++j) blocks[std::size_t(j)] = j < 30 ? j / 6 : -1;  // 5 blocks of 6
  std::mt19937 rng(9);
  std::normal_distribution<double> g;
  Eigen::VectorXd delta(36);
  for (int j = 0; j < 36; ++j) delta[j] = g(rng);
  NodalVarianceExtras ex;
  ex.rigid_rows = &rr.Gr;
  const MatrixX3d x = b.mesh.nodes();
  ex.rigid_points = &x;
  ex.rigid_centre = rr.centre;
  ex.node_rotations = &rr.R;
  ex.delta = &delta;
  ex.blocks = &blocks;
  const NodalVariance nv = nodal_variance(b.model->factor(), b.model->dofs(), b.mesh.nodes(), rr.G,
                                          a, exact_prior(), ex);
  const double lambda = 1e5 * nv.prior.maxCoeff();
  const Eigen::MatrixXd S = dense_rigid(b, rr, a, lambda).second;
  // Restricted: δᵀ S⁻¹ δ of the augmented model → δᵀ P δ as λ → ∞.
  EXPECT_NEAR(nv.restricted_quadratic, delta.dot(S.ldlt().solve(delta)),
              1e-3 * nv.restricted_quadratic);
  // Held out: refit without each block (the others' conditional mean and covariance) and sum
  // r_bᵀ V_b⁻¹ r_b; 1e-3 relative (the λ limit).
  double quad = 0.0;
  for (int blk = 0; blk < 5; ++blk) {
    std::vector<int> in, out;
    for (int j = 0; j < 36; ++j) (blocks[std::size_t(j)] == blk ? out : in).push_back(j);
    const Eigen::MatrixXd Soo = S(in, in), Sbo = S(out, in), Sbb = S(out, out);
    const Eigen::LDLT<Eigen::MatrixXd> l(Soo);
    const Eigen::VectorXd r = delta(out) - Sbo * l.solve(Eigen::VectorXd(delta(in)));
    const Eigen::MatrixXd V = Sbb - Sbo * l.solve(Eigen::MatrixXd(Sbo.transpose()));
    quad += r.dot(V.ldlt().solve(r));
  }
  EXPECT_NEAR(nv.heldout_quadratic, quad, 1e-3 * quad);
  EXPECT_EQ(nv.heldout_blocks, 5);
  EXPECT_EQ(nv.heldout_rows, 30.0);
}

// The stated tracking accuracy (uncertainty.tracking_*) against its closed form: a translation
// of RMS length σ_t adds σ_t² to every node's tr Σ; a rotation of RMS angle σ_r about the rows'
// centroid c adds tr(h Σθ hᵀ), h = [I, −[x − c]×], Σθ = σ_r²/3 I on the rotation (built here from
// the 6×6 pose covariance, not from the library's (2/3) σ_r² |x − c|²): it grows as the squared
// lever arm. Neither depends on s², and the default (0) adds nothing.
TEST(Uncertainty, AStatedTrackingAccuracyAddsItsClosedForm) {
  const Scene scene;
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;  // the loop from the tracked frame (the scene's own frame)
  IntraopData data;
  data.vessel_points = sample_deformed(scene.skeleton, 0.3, 11);
  const RegistrationResult r = register_model(*scene.model, data, o);
  const UncertaintyResult base = predict_uncertainty(*scene.model, r, o);
  ASSERT_TRUE(base.estimated) << base.estimation;
  ASSERT_EQ(base.node_tracking.size(), base.node_variance.size());
  EXPECT_EQ(base.node_tracking.cwiseAbs().maxCoeff(), 0.0);  // default: not included
  RegistrationOptions ot = o;
  ot.uncertainty.tracking_translation_mm = 1.5;
  const UncertaintyResult t = predict_uncertainty(*scene.model, r, ot);
  RegistrationOptions orot = o;
  orot.uncertainty.tracking_rotation_deg = 2.0;
  const UncertaintyResult rot = predict_uncertainty(*scene.model, r, orot);
  EXPECT_EQ(t.s2, base.s2);  // the prior is added, not fitted: s² is the data's alone
  const double sr = 2.0 * M_PI / 180.0;
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Zero();
  cov.bottomRightCorner<3, 3>() = sr * sr / 3.0 * Matrix3d::Identity();
  const Vector3d c = rot.tracking_centre;
  double near_d = 1e300, far_d = 0, near_v = 0, far_v = 0;
  for (index_t i = 0; i < r.positions.rows(); ++i) {
    // 1e-9 relative: the two variances differ by the added term only (same s², same traces).
    const double tol = 1e-9 * (1.0 + base.node_variance[i]);
    EXPECT_NEAR(t.node_variance[i] - base.node_variance[i], 1.5 * 1.5, tol) << "node " << i;
    const Vector3d d = r.positions.row(i).transpose() - c;
    Eigen::Matrix<double, 3, 6> h;
    h.leftCols<3>().setIdentity();
    h.rightCols<3>() << 0, d.z(), -d.y(), -d.z(), 0, d.x(), d.y(), -d.x(), 0;  // −[d]×
    const double expected = (h * cov * h.transpose()).trace();
    EXPECT_NEAR(rot.node_variance[i] - base.node_variance[i], expected, tol) << "node " << i;
    if (d.norm() < near_d) near_d = d.norm(), near_v = rot.node_tracking[i];
    if (d.norm() > far_d) far_d = d.norm(), far_v = rot.node_tracking[i];
  }
  // Grows as distance²: the farthest node's added variance over the nearest's is their squared
  // distance ratio (1e-9 relative: exact arithmetic up to rounding).
  ASSERT_GT(near_v, 0.0);
  EXPECT_NEAR(far_v / near_v, (far_d * far_d) / (near_d * near_d),
              1e-9 * (far_d * far_d) / (near_d * near_d));
  // The centre is the rows' centroid: inside the vessel points' bounding box (grown by 5 mm: the
  // rows lie on the model's skeleton, the points scatter 0.3 mm about the deformed one).
  const MatrixX3d& vp = data.vessel_points;
  EXPECT_TRUE((c.array() >= vp.colwise().minCoeff().transpose().array() - 5.0).all() &&
              (c.array() <= vp.colwise().maxCoeff().transpose().array() + 5.0).all())
      << c.transpose();
  EXPECT_NE(rot.estimation.find("stated tracking accuracy"), std::string::npos) << rot.estimation;
}

// The χ² quantiles behind the upper confidence bound of s², against tabulated values (4
// significant digits in the tables: 1e-3 relative).
TEST(Uncertainty, ChiSquareQuantilesMatchTheTables) {
  EXPECT_NEAR(chi2_quantile(1, 0.05), 0.003932, 1e-3 * 0.003932);
  EXPECT_NEAR(chi2_quantile(6, 0.05), 1.635, 1e-3 * 1.635);
  EXPECT_NEAR(chi2_quantile(21, 0.05), 11.59, 1e-3 * 11.59);
  EXPECT_NEAR(chi2_quantile(10, 0.95), 18.31, 1e-3 * 18.31);
  EXPECT_NEAR(chi2_quantile(100, 0.5), 99.33, 1e-3 * 99.33);
  EXPECT_THROW((void)chi2_quantile(0, 0.5), brainshift::Error);
  EXPECT_THROW((void)chi2_quantile(5, 1.0), brainshift::Error);
}

// The upper confidence bound multiplies the point estimate by k / χ²_{1−c}(k), k the held-out
// vessel blocks; 0 gives the point estimate (1e-12 relative: the same numbers).
TEST(Uncertainty, TheScaleBoundIsThePointEstimateTimesItsChiSquareFactor) {
  const Scene scene;
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;  // the loop from the tracked frame (the scene's own frame)
  IntraopData data;
  data.vessel_points = sample_deformed(scene.skeleton, 0.3, 11);
  const RegistrationResult r = register_model(*scene.model, data, o);
  RegistrationOptions point = o;
  point.uncertainty.scale_confidence = 0.0;
  const UncertaintyResult u = predict_uncertainty(*scene.model, r, o);
  const UncertaintyResult p = predict_uncertainty(*scene.model, r, point);
  ASSERT_TRUE(u.estimated && p.estimated) << u.estimation;
  ASSERT_GT(u.heldout_blocks, 0);
  EXPECT_EQ(u.scale_rows, static_cast<double>(u.heldout_blocks));
  const double factor = u.scale_rows / chi2_quantile(u.scale_rows, 0.05);
  EXPECT_NEAR(u.scale_factor, factor, 1e-12 * factor);
  EXPECT_EQ(p.scale_factor, 1.0);
  EXPECT_NEAR(u.s2, p.s2 * factor, 1e-12 * u.s2);
  EXPECT_NEAR(p.s2, p.s2_ml, 1e-12 * p.s2);  // the default estimator, unraised
}

// The default estimator follows the pose's origin: maximum likelihood for a pose searched on
// the sweep (or the identity), the held-out blocks' scale for a pose given by another sweep
// (UncertaintyOptions::ScaleEstimator::BY_POSE). The same registration read both ways: each
// s² is its candidate times the same χ² factor (1e-12 relative: the same numbers), and the map
// scales with √s² where the tracking and pose terms are zero (no tracking prior, no searched
// pose accepted).
TEST(Uncertainty, TheDefaultScaleFollowsWhetherThePoseWasGiven) {
  const Scene scene;
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;
  IntraopData data;
  data.vessel_points = sample_deformed(scene.skeleton, 0.3, 11);
  data.pose = Eigen::Isometry3d::Identity();
  const RegistrationResult given = register_model(*scene.model, data, o);
  ASSERT_TRUE(given.start.pose_given);
  RegistrationResult searched = given;
  searched.start.pose_given = false;
  const UncertaintyResult ug = predict_uncertainty(*scene.model, given, o);
  const UncertaintyResult us = predict_uncertainty(*scene.model, searched, o);
  ASSERT_TRUE(ug.estimated && us.estimated) << ug.estimation;
  ASSERT_GT(ug.heldout_blocks, 0);
  EXPECT_EQ(ug.scale_estimator, UncertaintyOptions::ScaleEstimator::HELD_OUT);
  EXPECT_EQ(us.scale_estimator, UncertaintyOptions::ScaleEstimator::MAXIMUM_LIKELIHOOD);
  EXPECT_NEAR(ug.s2, ug.s2_heldout * ug.scale_factor, 1e-12 * ug.s2);
  EXPECT_NEAR(us.s2, us.s2_ml * us.scale_factor, 1e-12 * us.s2);
  EXPECT_NE(ug.estimation.find("held-out"), std::string::npos) << ug.estimation;
  const double root = std::sqrt(ug.s2 / us.s2);
  for (index_t i = 0; i < ug.node_sigma_mm.size(); ++i)
    ASSERT_NEAR(ug.node_sigma_mm[i], root * us.node_sigma_mm[i], 1e-9 + 1e-9 * ug.node_sigma_mm[i]);
  // A pose given and the identity searched from are the same frame: one registration.
  IntraopData searched_data = data;
  searched_data.pose.reset();
  const RegistrationResult identity = register_model(*scene.model, searched_data, o);
  EXPECT_FALSE(identity.start.pose_given);
}

// Against the analytic sag (sag_scene.hpp: a truth field not made by the model), with the pose
// given: the held-out scale follows the fit and ML follows the sag's size. The same sag at half
// and at full size, the same 0.3 mm noise draw; the map's calibration read at the 72 free nodes
// within 5 mm of a vessel (where the rows inform it), actual |x − (X + u_truth(X))| against
// predicted σ, with the point estimates of s² (no χ² bound: 6 blocks would widen both × 3.7).
// Measured (2026-12-07): ML / held-out 1.80 at half size and 2.78 at full; RMS actual /
// predicted 0.72 and 1.02 with the held-out scale, 0.54 and 0.61 with ML. Asked: the held-out
// map within a factor 2 of calibrated at both sizes (the bar); closer to calibrated than
// ML's in log terms at both; and ML outgrowing the held-out scale as the sag doubles (× 1.2 at
// least: measured × 1.54; the fit's error grows with the sag too, this being no model response).
TEST(Uncertainty, WithAGivenPoseTheScaleFollowsTheFitNotTheSagsSize) {
  const Scene scene;
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;
  o.uncertainty.scale_confidence = 0.0;  // the point estimates, to compare the estimators
  RegistrationOptions ml = o;
  ml.uncertainty.scale_estimator = UncertaintyOptions::ScaleEstimator::MAXIMUM_LIKELIHOOD;
  // RMS of actual / predicted at the free nodes within 5 mm of a vessel.
  auto rms_ratio = [&](const RegistrationResult& r, const UncertaintyResult& u, double size) {
    const MatrixX3d& X = scene.mesh.nodes();
    double sum = 0.0;
    int k = 0;
    for (index_t i = 0; i < X.rows(); ++i) {
      if (scene.model->mechanics().dofs().is_fixed_node(i)) continue;
      const Vector3d x0 = X.row(i).transpose();
      double near = 1e9;
      for (index_t j = 0; j < scene.skeleton.points.rows(); ++j)
        near = std::min(near, (scene.skeleton.points.row(j).transpose() - x0).norm());
      if (near > 5.0) continue;
      const double actual = (r.positions.row(i).transpose() - (x0 + size * truth(x0))).norm();
      sum += std::pow(actual / u.node_sigma_mm[i], 2), ++k;
    }
    EXPECT_GT(k, 20);
    return std::sqrt(sum / std::max(k, 1));
  };
  std::vector<double> ml_over_heldout;
  for (double size : {0.5, 1.0}) {
    IntraopData data;
    data.vessel_points = sample_deformed(scene.skeleton, 0.3, 11, size);
    data.pose = Eigen::Isometry3d::Identity();
    const RegistrationResult r = register_model(*scene.model, data, o);
    const UncertaintyResult u = predict_uncertainty(*scene.model, r, o);
    const UncertaintyResult v = predict_uncertainty(*scene.model, r, ml);
    ASSERT_TRUE(u.estimated && v.estimated) << u.estimation;
    EXPECT_EQ(u.scale_estimator, UncertaintyOptions::ScaleEstimator::HELD_OUT);
    const double ru = rms_ratio(r, u, size), rv = rms_ratio(r, v, size);
    std::printf(
        "sag x %.1f: s2 ML %.4g, held-out %.4g (%lld blocks); rms actual/predicted "
        "held-out %.3f, ML %.3f\n",
        size, u.s2_ml, u.s2_heldout, static_cast<long long>(u.heldout_blocks), ru, rv);
    EXPECT_GT(ru, 0.5) << "sag x " << size;
    EXPECT_LT(ru, 2.0) << "sag x " << size;
    EXPECT_LT(std::abs(std::log(ru)), std::abs(std::log(rv))) << "sag x " << size;
    ml_over_heldout.push_back(u.s2_ml / u.s2_heldout);
  }
  EXPECT_GT(ml_over_heldout[1], 1.2 * ml_over_heldout[0]);
}

TEST(Uncertainty, BadOptionsAreRefused) {
  UncertaintyOptions o;
  o.scale_confidence = 1.0;
  EXPECT_FALSE(o.validate().empty());
  o = {};
  o.tracking_translation_mm = -1;
  EXPECT_FALSE(o.validate().empty());
  o = {};
  o.tracking_rotation_deg = std::nan("");
  EXPECT_FALSE(o.validate().empty());
  o = {};
  o.hard_row_ratio = 0;
  EXPECT_FALSE(o.validate().empty());
  o = {};
  o.calibration = -1;
  EXPECT_FALSE(o.validate().empty());
  EXPECT_TRUE(UncertaintyOptions{}.validate().empty());
}

}  // namespace
}  // namespace brainshift::constraints
