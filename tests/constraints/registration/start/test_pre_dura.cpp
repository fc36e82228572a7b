// The pose from a sweep before the dura is opened (IntraopData::pose, pre_dura_pose()) and the
// bulk shift carried as a load (RegistrationOptions::bulk_as_load), on the analytic sag scene
// (sag_scene.hpp): a known navigation offset is measured on the undeformed vessels and kept; the
// deformation alone then carries the sag, so the fixed base stays where the truth has it; and the
// load the start's bulk shift becomes reproduces that shift at the vessel points.
#include "tests/constraints/registration/sag_scene.hpp"

#include "constraints/registration/start/run_start.hpp"
#include "constraints/registration/uncertainty/uncertainty.hpp"
#include "core/error.hpp"
#include "core/fem/corotational.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <limits>
#include <numbers>
#include <random>

namespace brainshift::constraints {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/// The navigation offset of these tests: intra-operative points are O · p_model.
Eigen::Isometry3d navigation_offset() {
  Eigen::Isometry3d O = Eigen::Isometry3d::Identity();
  O.rotate(Eigen::AngleAxisd(4.0 * kDeg, Vector3d(1, -2, 0.5).normalized()));
  O.pretranslate(Vector3d(6.0, -5.0, 3.0));
  return O;
}

MatrixX3d apply(const Eigen::Isometry3d& T, const MatrixX3d& p) {
  return ((p * T.linear().transpose()).rowwise() + T.translation().transpose()).eval();
}

TEST(PreDura, ThePoseOfTheUndeformedSweepIsKeptAndTheSagGoesToTheDeformation) {
  Scene s;
  const Eigen::Isometry3d O = navigation_offset();
  // Before opening: the rest vessels through the offset; after: the sagged ones, same offset.
  const MatrixX3d before = apply(O, sample_deformed(s.skeleton, 0.3, 11, 0.0));
  IntraopData d;
  d.vessel_points = apply(O, sample_deformed(s.skeleton, 0.3, 12, 1.0));
  RegistrationOptions o;
  o.start = RigidStart::RIGID;
  o.max_iterations = 60;
  // The loop itself (its deformation carries the sag): the noise model's choice of the start
  // over the deformation is off, as in test_registration.cpp, on the same scene.
  o.noise.enabled = false;

  const StartResult pre = pre_dura_pose(*s.model, before, o);
  ASSERT_TRUE(pre.accepted) << pre.message;
  // The pose of 0.3 mm-noise points over a 60 mm field: within 0.5 mm of the truth at every fixed
  // node (the farthest from the vessels, ≈ 50 mm away): a 0.3° error there would be 0.26 mm.
  std::vector<index_t> fixed;
  for (index_t i = 0; i < s.mesh.num_nodes(); ++i)
    if (s.mesh.nodes()(i, 2) < -22) fixed.push_back(i);
  MatrixX3d base(static_cast<Eigen::Index>(fixed.size()), 3);
  for (std::size_t k = 0; k < fixed.size(); ++k)
    base.row(static_cast<Eigen::Index>(k)) = s.mesh.nodes().row(fixed[k]);
  const auto base_error = [&](const Eigen::Isometry3d& model_from_intra) {
    // Where a registration puts the (unmoving) base in the intra-operative frame, against where
    // the offset puts it.
    return (apply(model_from_intra.inverse(), base) - apply(O, base)).rowwise().norm().maxCoeff();
  };
  EXPECT_LT(base_error(pre.transform), 0.5) << pre.message;

  d.pose = pre.transform;
  const RegistrationResult r = register_model(*s.model, d, o);
  ASSERT_TRUE(r.converged) << r.stop_reason;
  // The given pose is the answer's pose, bit for bit: the start searched only the bulk shift.
  EXPECT_TRUE(r.start.transform.isApprox(pre.transform, 0.0)) << r.start.stop_reason;
  EXPECT_NE(r.start.stop_reason.find("given pose"), std::string::npos) << r.start.stop_reason;
  // With a given pose the bulk shift is the sag itself, and `auto` carries it as a load.
  ASSERT_TRUE(r.start.bulk_accepted) << r.start.bulk_message;
  EXPECT_GT(r.bulk_gravity.norm(), 0.0);
  EXPECT_LT(base_error(r.start.transform), 0.5);
  // The deformation carries the sag (10 mm at the top): the skeleton lands within 1 mm on average
  // (the noise-free registration reaches ≈ 0.3 mm; 0.3 mm noise, 10 mm elements).
  const auto [mean, max] = s.landmark_error(r.positions);
  EXPECT_LT(mean, 1.0) << "max " << max << "; " << r.stop_reason;
  std::cout << "[ pre-dura ] base error " << base_error(r.start.transform) << " mm; skeleton "
            << mean << " mean, " << max << " max mm; " << r.iterations << " iterations\n";
}

TEST(PreDura, APoseThatIsNotARotationAndTranslationIsRefused) {
  Scene s;
  IntraopData d;
  d.vessel_points = sample_deformed(s.skeleton, 0.3, 1);
  Eigen::Isometry3d scaled = Eigen::Isometry3d::Identity();
  scaled.linear() *= 1.01;
  d.pose = scaled;
  EXPECT_THROW((void)register_model(*s.model, d, RegistrationOptions{}), Error);
  d.pose = Eigen::Isometry3d::Identity();
  d.pose->translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)register_model(*s.model, d, RegistrationOptions{}), Error);
}

TEST(PreDura, APoseSearchedOnTheSweepAddsItsMotionWhereTheSagDoesNotReach) {
  // The predicted error's confounded-pose term (UncertaintyOptions::pose_confounded): on the
  // fixed base (no load response) it is the pose's whole motion, exactly; near the data it is
  // small; with the pose given by a pre-dura sweep, or switched off, it is absent.
  Scene s;
  const Eigen::Isometry3d O = navigation_offset();
  IntraopData d;
  d.vessel_points = apply(O, sample_deformed(s.skeleton, 0.3, 12, 1.0));
  RegistrationOptions o;
  o.start = RigidStart::RIGID;
  const RegistrationResult r = register_model(*s.model, d, o);
  ASSERT_TRUE(r.start.accepted) << r.start.message;
  const UncertaintyResult u = predict_uncertainty(*s.model, r, o);
  ASSERT_EQ(u.node_pose.size(), s.mesh.num_nodes());
  const Eigen::Isometry3d to_intra = r.start.transform.inverse();
  double base = 0.0, data = 0.0;
  int nb = 0, nd = 0;
  std::vector<bool> at_data(static_cast<std::size_t>(s.mesh.num_nodes()), false);
  for (index_t i = 0; i < r.data_rows.size(); ++i)
    for (int k = 0; k < r.data_rows[i].stencil.size; ++k)
      at_data[static_cast<std::size_t>(r.data_rows[i].stencil.node[static_cast<std::size_t>(k)])] =
          true;
  for (index_t i = 0; i < s.mesh.num_nodes(); ++i) {
    const Vector3d x = r.positions.row(i).transpose();
    if (s.model->mechanics().dofs().is_fixed_node(i)) {
      // ρ = 0 on a fixed node: the term is the pose's motion squared (round-off only).
      EXPECT_NEAR(u.node_pose[i], (to_intra * x - x).squaredNorm(),
                  1e-9 * (1 + (to_intra * x - x).squaredNorm()));
      base += u.node_pose[i], ++nb;
    }
    if (at_data[static_cast<std::size_t>(i)]) data += u.node_pose[i], ++nd;
  }
  ASSERT_GT(nb, 0);
  ASSERT_GT(nd, 0);
  // Near the data the load response is about the data's mean, so the term nearly vanishes: at
  // most a quarter of the base's (mm², measured far below).
  EXPECT_LT(data / nd, 0.25 * base / nb) << data / nd << " vs " << base / nb;

  RegistrationOptions off = o;
  off.uncertainty.pose_confounded = false;
  EXPECT_EQ(predict_uncertainty(*s.model, r, off).node_pose.norm(), 0.0);
  IntraopData given = d;
  given.pose = r.start.transform;
  const RegistrationResult g = register_model(*s.model, given, o);
  EXPECT_EQ(predict_uncertainty(*s.model, g, o).node_pose.norm(), 0.0);
}

TEST(BulkLoad, TheLoadReproducesTheStartsBulkShiftAtTheVesselPoints) {
  // The body acceleration the loop carries is an independent check of the amplitude: the linear
  // model's response to it, averaged over the vessel points' nearest nodes, is the start's bulk
  // shift (load_basis()'s normalisation), to round-off.
  Scene s;
  IntraopData d;
  d.vessel_points = sample_deformed(s.skeleton, 0.3, 1);
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;  // the bulk-shift search alone: the whole sag is a bulk shift
  o.bulk_as_load = BulkLoad::ON;
  const RegistrationResult r = register_model(*s.model, d, o);
  ASSERT_TRUE(r.start.bulk_accepted) << r.start.bulk_message;
  ASSERT_GT(r.bulk_gravity.norm(), 0.0);
  StepOptions linear;
  linear.mechanics = Mechanics::LINEAR;
  linear.gravity = r.bulk_gravity;
  const MatrixX3d u =
      s.model->mechanics().step(s.mesh.nodes(), ConstraintRows{}, linear).x - s.mesh.nodes();
  Vector3d mean = Vector3d::Zero();
  for (Eigen::Index i = 0; i < d.vessel_points.rows(); ++i) {
    Eigen::Index node = 0;
    (s.mesh.nodes().rowwise() - d.vessel_points.row(i)).rowwise().squaredNorm().minCoeff(&node);
    mean += u.row(node).transpose() / static_cast<double>(d.vessel_points.rows());
  }
  EXPECT_LT((mean - r.start.bulk_shift).norm(), 1e-6 * r.start.bulk_shift.norm())
      << "mean response " << mean.transpose() << " vs shift " << r.start.bulk_shift.transpose();
}

/// The model's own linear response to a downward body load (a direct solve), scaled to `top_mm`
/// at the top, at the skeleton points (`truth`), and those points with 0.3 mm Gaussian noise per
/// axis as the Doppler's (`data`).
struct LoadSag {
  MatrixX3d truth;
  IntraopData data;
};
LoadSag load_response_sag(const Scene& s, double top_mm, unsigned seed) {
  StepOptions linear;
  linear.mechanics = Mechanics::LINEAR;
  linear.gravity = Vector3d(0, 0, -9810.0);
  MatrixX3d u =
      s.model->mechanics().step(s.mesh.nodes(), ConstraintRows{}, linear).x - s.mesh.nodes();
  u *= top_mm / u.col(2).cwiseAbs().maxCoeff();
  LoadSag out;
  out.truth = s.model->skeleton_mapping().apply(s.mesh.nodes() + u);
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 0.3);
  out.data.vessel_points = out.truth;
  for (Eigen::Index i = 0; i < out.truth.rows(); ++i)
    out.data.vessel_points.row(i) += Vector3d(g(rng), g(rng), g(rng)).transpose();
  return out;
}

/// The load sag (load_response_sag()) registered twice from the tracked frame with a pre-dura
/// pose: with the default options (`a`) and with `change` applied (`b`); their skeleton mean
/// errors against the truth (mm) and the largest node gap between the two answers (mm).
struct OnOff {
  RegistrationResult a, b;
  double error_a = 0.0, error_b = 0.0, node_gap = 0.0;
};
OnOff register_with_and_without(const Scene& s, double top_mm, unsigned seed,
                                const std::function<void(RegistrationOptions&)>& change) {
  auto [truth, d] = load_response_sag(s, top_mm, seed);
  d.pose = Eigen::Isometry3d::Identity();  // as from a pre-dura sweep: the load is AUTO-on
  RegistrationOptions on, off;
  on.start = off.start = RigidStart::IDENTITY;
  change(off);
  OnOff r;
  r.a = register_model(*s.model, d, on);
  r.b = register_model(*s.model, d, off);
  const auto error = [&](const RegistrationResult& x) {
    return (s.model->skeleton_mapping().apply(x.positions) - truth).rowwise().norm().mean();
  };
  r.error_a = error(r.a);
  r.error_b = error(r.b);
  r.node_gap = (r.a.positions - r.b.positions).rowwise().norm().maxCoeff();
  return r;
}

TEST(BulkLoad, ASagThatIsTheModelsOwnLoadResponseIsMetWithoutTheCompliantRowsLag) {
  // The truth is the model's own linear response to a downward body load (a direct solve),
  // scaled to 10 mm at the top. Compliant vessel rows (ratio 0.2) balance the elastic force of
  // the displacement they hold, so from the rest shape they lag the data by a share of it; with
  // the start's bulk shift carried as the load, the elastic rest is the shifted state, which here
  // is the truth up to the shift's amplitude, and only that remainder lags.
  Scene s;
  const auto [truth, d] = load_response_sag(s, 10.0, 5);
  RegistrationOptions with, without;
  with.start = without.start = RigidStart::IDENTITY;  // the pose is right; the sag is the shift
  with.bulk_as_load = BulkLoad::ON;
  without.bulk_as_load = BulkLoad::OFF;
  const RegistrationResult a = register_model(*s.model, d, with);
  const RegistrationResult b = register_model(*s.model, d, without);
  std::cout << "[ bulk load ] " << to_string(a.stop) << " / " << to_string(b.stop) << "\n";
  EXPECT_TRUE(b.bulk_gravity.isZero());
  auto error = [&](const RegistrationResult& r) {
    return (s.model->skeleton_mapping().apply(r.positions) - truth).rowwise().norm().mean();
  };
  const double ea = error(a), eb = error(b);
  std::cout << "[ bulk load ] skeleton mean error " << ea << " mm with the load, " << eb
            << " mm without\n";
  // With the load the answer is at the noise floor (0.3 mm per axis, averaged by the compliant
  // rows over neighbours: < 0.4 mm; 0.52 mm RMS per point), and clearly better than the lagging
  // answer.
  EXPECT_LT(ea, 0.4);
  EXPECT_LT(ea, 0.8 * eb);
  EXPECT_TRUE(a.converged) << a.stop_reason;
  EXPECT_TRUE(b.converged) << b.stop_reason;
}

TEST(BulkLoad, ALargeSagUnderItsLoadSettlesFromThePreStrainedRest) {
  // The same sag at 12 mm: on this 60 mm-high model with an 8 mm fixed base that is what the
  // large_shift phantom's 19 mm is to a brain. Carried as a body force the corotational
  // iteration did not settle under it (not_settling after 56 iterations, measured; 14 mm: 37
  // elements inverted; on the large_shift phantom up to 28 and the iteration cap): the warped
  // compliance lacks the geometric stiffness of a large load. Carried as the elastic rest
  // (core::RestShape) the load's equilibrium is stress free and the loop only corrects the
  // remainder: it converges (36 iterations), with no element inverted on the way.
  Scene s;
  auto [truth, d] = load_response_sag(s, 12.0, 7);
  d.pose = Eigen::Isometry3d::Identity();  // as from a pre-dura sweep: the load is AUTO-on
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;  // the loop from the tracked frame (the scene's own frame)
  index_t inverted = 0;
  o.inspect_step = [&](StepResult& r) { inverted = std::max(inverted, r.inverted_elements); };
  const RegistrationResult r = register_model(*s.model, d, o);
  ASSERT_GT(r.bulk_gravity.norm(), 0.0);
  const double e = (s.model->skeleton_mapping().apply(r.positions) - truth).rowwise().norm().mean();
  std::cout << "[ bulk load ] 12 mm sag: " << to_string(r.stop) << " in " << r.iterations
            << " iterations, skeleton mean error " << e << " mm, " << inverted
            << " inverted elements at most\n";
  EXPECT_TRUE(r.converged) << r.stop_reason;
  EXPECT_EQ(inverted, 0);
  // The 10 mm test's floor (0.4 mm; measured 0.16 here with the load's share, 0.29 with the whole
  // load and its two flattened elements at the mesh's rest, 0.39 with the body force).
  EXPECT_LT(e, 0.4);
}

TEST(BulkLoad, ALoadPathThatDoesNotSettleIsRunAgainWithoutTheLoad) {
  // RegistrationOptions::load_retry. Fault injection: the free node farthest from the vessels
  // (the pairing does not feel it) is pushed ±1 mm along z after every step of the run that
  // carries the bulk shift as a load, which then ends NOT_SETTLING; the retry without the load,
  // whose steps come after those, is clean. Independent answer: the same registration with the
  // load off from the start (BulkLoad::OFF), which the retry must equal.
  Scene s;
  auto [truth, d] = load_response_sag(s, 10.0, 7);
  d.pose = Eigen::Isometry3d::Identity();  // the load is AUTO-on
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;
  const auto [node, farthest] = farthest_free_node(s);
  ASSERT_GE(node, 0);
  o.load_retry = false;
  o.inspect_step = push_back_and_forth(s, node, 1.0, std::numeric_limits<int>::max());
  const RegistrationResult stuck = register_model(*s.model, d, o);
  ASSERT_EQ(stuck.stop, RegistrationStop::NOT_SETTLING) << stuck.stop_reason;
  ASSERT_GT(stuck.bulk_gravity.norm(), 0.0);
  const int steps = stuck.iterations;

  o.load_retry = true;
  o.inspect_step = push_back_and_forth(s, node, 1.0, steps);
  const RegistrationResult r = register_model(*s.model, d, o);
  RegistrationOptions off;
  off.start = RigidStart::IDENTITY;
  off.bulk_as_load = BulkLoad::OFF;
  const RegistrationResult reference = register_model(*s.model, d, off);
  std::cout << "[ load retry ] node " << node << " (" << farthest
            << " mm from the vessels): " << r.stop_reason << "\n";
  EXPECT_TRUE(r.load_retry);
  EXPECT_TRUE(r.converged) << r.stop_reason;
  EXPECT_TRUE(r.bulk_gravity.isZero());
  EXPECT_NE(r.stop_reason.find("without it"), std::string::npos) << r.stop_reason;
  ASSERT_TRUE(reference.converged) << reference.stop_reason;
  // The same options and data give the same answer (a deterministic loop): to round-off.
  EXPECT_LT((r.positions - reference.positions).cwiseAbs().maxCoeff(), 1e-9);
  // Without the fault the load's path converges and is kept: no retry.
  o.inspect_step = nullptr;
  EXPECT_FALSE(register_model(*s.model, d, o).load_retry);
}

TEST(BulkLoad, ALoadWhoseResponseFlattensAnElementIsCarriedAtTheLargestShareThatFlattensNone) {
  // detail::bulk_rest(): at 12 mm the model's own linear response flattens two elements (a
  // small-strain answer to a large load). The rest is then the largest share of the load with
  // none flattened: checked against the element test itself one bisection step above the share,
  // and against the truth, which the registration meets better than with the whole load's rest
  // (its flattened elements kept at the mesh's rest: 0.29 mm, measured before the share).
  Scene s;
  auto [truth, d] = load_response_sag(s, 12.0, 7);
  d.pose = Eigen::Isometry3d::Identity();
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;
  const RegistrationResult r = register_model(*s.model, d, o);
  ASSERT_GT(r.bulk_gravity.norm(), 0.0);
  // r.bulk_gravity is the share the registration carried; twice it flattens elements too.
  const Vector3d whole = 2.0 * r.bulk_gravity;
  double share = 0.0;
  const auto rest = detail::bulk_rest(*s.model, whole, o, &share);
  ASSERT_TRUE(rest != nullptr);
  EXPECT_GT(share, 0.0);
  EXPECT_LT(share, 1.0);
  EXPECT_EQ(rest->degenerate, 0);
  const core::CorotationalModel& fem = s.model->mechanics().model();
  MatrixX3d response = MatrixX3d::Zero(s.mesh.num_nodes(), 3);
  const Vector3d one = detail::bulk_gravity(Vector3d::Ones(), o);
  for (int k = 0; k < 3; ++k) response += (whole[k] / one[k]) * s.model->load_response()[k];
  EXPECT_EQ(fem.rest_shape(s.mesh.nodes() + share * response).degenerate, 0);
  EXPECT_GT(fem.rest_shape(s.mesh.nodes() + (share + 2.0 / 4096) * response).degenerate, 0);
  const double e = (s.model->skeleton_mapping().apply(r.positions) - truth).rowwise().norm().mean();
  std::cout << "[ bulk load ] share " << share << " of twice the 12 mm sag's load; the 12 mm "
            << "registration's skeleton error " << e << " mm\n";
  EXPECT_TRUE(r.converged) << r.stop_reason;
  // Better than the whole load's rest did (0.29 mm) by more than the run-to-run change of the
  // path (the same data and options give the same answer to 1e-6 mm; 0.25 leaves 0.04 mm).
  EXPECT_LT(e, 0.25);
}

TEST(BulkLoad, StartingAtTheLoadsRestReachesTheSameAnswerInFewerIterations) {
  // RegistrationOptions::start_at_load_rest moves only the iterate's start (to the load's rest,
  // where the elastic force is zero) and keeps the HELD stage's first pairs where they were made
  // from the rest nodes; so the equilibrium is the same and only the path is shorter. Independent
  // answer: the same registration with the option off, and the sag's truth. At 10 mm (the 12 mm
  // sag's linear response inverts two elements, and there the option stands aside).
  Scene s;
  const OnOff r = register_with_and_without(
      s, 10.0, 7, [](RegistrationOptions& o) { o.start_at_load_rest = false; });
  ASSERT_GT(r.a.bulk_gravity.norm(), 0.0);
  std::cout << "[ load rest ] " << r.a.iterations << " vs " << r.b.iterations
            << " iterations; skeleton error " << r.error_a << " vs " << r.error_b
            << " mm; largest node gap " << r.node_gap << " mm\n";
  EXPECT_TRUE(r.a.converged) << r.a.stop_reason;
  EXPECT_TRUE(r.b.converged) << r.b.stop_reason;
  // From the rest nodes the first steps are the fall into the load's rest, cut to the 5 mm
  // trust radius: for a 10 mm sag at least two (measured 16 against 22 iterations).
  EXPECT_LT(r.a.iterations, r.b.iterations);
  // Both stop on the same test (a relative change of the iterate): the two answers differ by
  // what the stop test leaves, well under the 0.3 mm noise of the data; the error stays at the
  // 10 mm test's floor.
  EXPECT_LT(r.node_gap, 0.3);
  EXPECT_LT(r.error_a, 0.4);
}

TEST(BulkLoad, TailJumpsReachTheSameAnswer) {
  // RegistrationOptions::extrapolate_tails takes a stage's contracting tail at once
  // (tail_jump_factor()) and still asks the step after the jump to be below the tolerance; the
  // fixed point is the loop's own. Independent answers: the same registration with every step
  // taken, and the sag's truth (the model's own linear response to the 12 mm load, sampled with
  // 0.3 mm noise; the 10 mm sag settles in 16 iterations with no tail to take).
  Scene s;
  const OnOff r = register_with_and_without(
      s, 12.0, 7, [](RegistrationOptions& o) { o.extrapolate_tails = false; });
  int jumps = 0;
  for (const IterationRecord& h : r.a.history) jumps += h.extrapolated_mm > 0.0;
  std::cout << "[ tail ] " << r.a.iterations << " vs " << r.b.iterations << " iterations, " << jumps
            << " jumps; skeleton error " << r.error_a << " vs " << r.error_b
            << " mm; largest node gap " << r.node_gap << " mm\n";
  EXPECT_TRUE(r.a.converged) << r.a.stop_reason;
  EXPECT_TRUE(r.b.converged) << r.b.stop_reason;
  EXPECT_GE(jumps, 1);
  // The iterations are not asserted: a jump saves the steps of a tail it takes, and costs a step
  // where the next one turns back (here 37 against 35 iterations; over the 13 bench cases
  // 352 against 368, docs/BENCHMARKS.md).
  // Both stop below 0.01 mm a step; what that leaves of a tail contracting at ≤ 0.9 is
  // ≤ 0.09 mm on each side: 0.2 mm, under the data's 0.3 mm noise. The error stays at the
  // 10 mm test's floor.
  EXPECT_LT(r.node_gap, 0.2);
  EXPECT_LT(r.error_a, 0.4);
}

TEST(PreDura, ThePairedTestUsesItsOwnBarWhenThePoseIsGiven) {
  // NoiseOptions::paired_test_z_with_pose replaces paired_test_z exactly when IntraopData::pose is
  // set. On the 10 mm load sag the deformation's held-out gain is positive, so a bar of 0 keeps
  // the deformation and a bar of 100 standard errors keeps the start; without a pose the same
  // key changes nothing.
  Scene s;
  auto [truth, d] = load_response_sag(s, 10.0, 11);
  d.pose = Eigen::Isometry3d::Identity();
  RegistrationOptions low, high;
  low.start = high.start = RigidStart::IDENTITY;
  low.noise.paired_test_z = high.noise.paired_test_z = 0.0;  // the one-sweep bar: no effect here
  low.noise.paired_test_z_with_pose = 0.0;
  high.noise.paired_test_z_with_pose = 100.0;
  const RegistrationResult a = register_model(*s.model, d, low);
  const RegistrationResult b = register_model(*s.model, d, high);
  ASSERT_TRUE(a.noise.valid) << a.noise.message;
  ASSERT_TRUE(b.noise.valid) << b.noise.message;
  std::cout << "[ paired test with pose ] " << a.noise.message << "\n";
  EXPECT_FALSE(a.noise.keep_start) << a.noise.message;
  EXPECT_TRUE(b.noise.keep_start) << b.noise.message;
  IntraopData no_pose = d;
  no_pose.pose.reset();
  const RegistrationResult c = register_model(*s.model, no_pose, low);
  const RegistrationResult e = register_model(*s.model, no_pose, high);
  EXPECT_EQ(c.noise.keep_start, e.noise.keep_start) << c.noise.message << "\n" << e.noise.message;
  EXPECT_EQ(c.iterations, e.iterations);
  EXPECT_EQ((c.positions - e.positions).cwiseAbs().maxCoeff(), 0.0);  // the same computation
}

/// Every `stride`-th point of a sweep over the analytic scene's vessels (sample_deformed(), 0.3 mm
/// noise per axis, the sag scaled by `sag`), with the pose given as from a pre-dura sweep.
IntraopData thinned_sweep(const Scene& s, unsigned seed, int stride, double sag) {
  const MatrixX3d all = sample_deformed(s.skeleton, 0.3, seed, sag);
  IntraopData d;
  d.vessel_points.resize((all.rows() + stride - 1) / stride, 3);
  for (Eigen::Index i = 0; i < d.vessel_points.rows(); ++i)
    d.vessel_points.row(i) = all.row(i * stride);
  d.pose = Eigen::Isometry3d::Identity();
  return d;
}

TEST(PreDura, WithThePoseGivenTheDeformationIsKeptOnAThinSweepWhereItIsRight) {
  // The analytic sag (sag_scene.hpp's truth(): 10 mm at the top, bending sideways) is not the
  // model's load response, so the start (rest + the bulk response) leaves ≈ 1.1 mm at the
  // vessel landmarks and the deformation is what meets it. Sweeps of 73, 37 and 25 points
  // (the bench's seed-3 sweep has 33), four noise draws each: the default (paired test at zero
  // standard errors with a pose, plain cross-validation) keeps the deformation on all twelve,
  // each at most 0.75 × the start's error against the closed form (measured 0.57-0.71 mm
  // against 1.10-1.19: ≤ 0.61×). The former bar of one standard error refused it on thin
  // sweeps (measured 6 of the 8 at 37 and 25 points), keeping an error twice as large.
  Scene s;
  int refused_at_z1 = 0;
  for (unsigned seed = 1; seed <= 4; ++seed)
    for (int stride : {1, 2, 3}) {
      const IntraopData d = thinned_sweep(s, seed, stride, 1.0);
      RegistrationOptions o;
      o.start = RigidStart::IDENTITY;
      RegistrationOptions z1 = o;
      z1.noise.paired_test_z_with_pose = 1.0;
      const RegistrationResult a = register_model(*s.model, d, o);
      const RegistrationResult start = start_only(*s.model, d, o);
      const double ea = s.landmark_error(a.positions).first;
      const double es = s.landmark_error(start.positions).first;
      std::cout << "[ thin sweep ] seed " << seed << ", " << d.vessel_points.rows()
                << " points: deformation " << ea << " mm, start " << es << " mm; "
                << a.noise.message << "\n";
      ASSERT_TRUE(a.noise.valid) << a.noise.message;
      EXPECT_FALSE(a.noise.keep_start) << a.noise.message;
      EXPECT_LT(ea, 0.75 * es);
      if (stride > 1 && register_model(*s.model, d, z1).noise.keep_start) ++refused_at_z1;
    }
  EXPECT_GE(refused_at_z1, 1);
}

TEST(PreDura, WithThePoseGivenAndNoSagAKeptDeformationCostsLittle) {
  // The other side of plain cross-validation: data with no sag at all (the rest vessels with
  // 0.3 mm noise per axis, 0.52 mm mean per point). Where a noise draw makes the deformation
  // look better on held-out branches it is kept (measured on 8 of these 12); what
  // that costs is its mean motion of the vessel landmarks from the truth (the rest): measured
  // ≤ 0.11 mm, asked ≤ 0.15 mm, under a third of the noise it fits.
  Scene s;
  for (unsigned seed = 1; seed <= 4; ++seed)
    for (int stride : {1, 2, 3}) {
      const IntraopData d = thinned_sweep(s, seed, stride, 0.0);
      RegistrationOptions o;
      o.start = RigidStart::IDENTITY;
      const RegistrationResult a = register_model(*s.model, d, o);
      ASSERT_TRUE(a.noise.valid) << a.noise.message;
      const double e = (s.model->skeleton_mapping().apply(a.positions) - s.skeleton.points)
                           .rowwise()
                           .norm()
                           .mean();
      std::cout << "[ no sag ] seed " << seed << ", " << d.vessel_points.rows() << " points: " << e
                << " mm; " << a.noise.message << "\n";
      EXPECT_LT(e, 0.15);
    }
}

}  // namespace
}  // namespace brainshift::constraints
