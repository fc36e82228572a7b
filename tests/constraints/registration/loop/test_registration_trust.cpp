// The loop's trust region (issue 14 item 4, issue 19 item 1): halving on a turn-back, holding a
// contracting one, damping one that does not contract below the radius, freezing a pairing that
// cycles; each checked on its rule and on a registration that needs it (fault injection where the
// scene alone would not show it reliably).
#include "tests/constraints/registration/sag_scene.hpp"

#include "constraints/registration/loop/registration_stage.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace brainshift::constraints {
namespace {

/// The scene for fault injection at one node: the sagged vessels sampled with 0.3 mm noise, one
/// FREE stage from the rest shape (no shift search, no noise model), the clean run's answer and
/// the free node farthest from the vessels (the pairing does not feel it).
struct FarNodeInjection {
  Scene s;
  IntraopData d;
  RegistrationOptions o = loop_options();
  RegistrationResult clean;
  index_t node = -1;
  double farthest = 0.0;
  FarNodeInjection() {
    d.vessel_points = sample_deformed(s.skeleton, 0.3, 1);
    o.global_start.bulk_search.enabled = false;  // the start is the rest shape, one FREE stage
    o.noise.enabled = false;
    clean = register_model(*s.model, d, o);
    std::tie(node, farthest) = farthest_free_node(s);
  }
};

TEST(RegistrationLoop, TrustRegionHalvesOnATurnBackAndGrowsOtherwise) {
  double radius = 4.0, damping = 1.0;
  EXPECT_EQ(trust_update({.cosine = std::nullopt, .length_ratio = 0.5}, 5.0, radius, damping),
            TrustDecision::NONE);
  EXPECT_EQ(radius, 4.0);
  // Turned back across a pairing change: the steps answer different data; halves.
  EXPECT_EQ(trust_update({.cosine = -0.2, .length_ratio = 1.0, .same_pairing = false}, 5.0, radius,
                         damping),
            TrustDecision::SHRINK);
  EXPECT_EQ(radius, 2.0);
  // Not turned back: grows, whatever the step's length, limit or pairs.
  EXPECT_EQ(trust_update({.cosine = 0.3, .length_ratio = 0.5}, 5.0, radius, damping),
            TrustDecision::GROW);
  EXPECT_EQ(radius, 3.0);
  EXPECT_EQ(trust_update({.cosine = 0.9, .length_ratio = 1.2, .same_pairing = false}, 5.0, radius,
                         damping),
            TrustDecision::GROW);
  EXPECT_EQ(
      trust_update({.cosine = 0.9, .length_ratio = 1.0, .limited = true}, 5.0, radius, damping),
      TrustDecision::GROW);
  EXPECT_EQ(radius, 5.0);   // capped at the maximum
  EXPECT_EQ(damping, 1.0);  // none of these damps
}

TEST(RegistrationLoop, TrustRegionHoldsOnAContractingTurnBackOnly) {
  // The rule's cases against slow_reversal_ratio (0.5) and contraction_bound (0.9,
  // registration_stage.hpp): ratios well on either side of them, and at them.
  double radius = 2.0, damping = 1.0;
  // Turned back at 0.4 of the previous step, unlimited, same pairs: a converging oscillation
  // that halves by itself; held. At slow_reversal_ratio itself, too; and a weak turn-back
  // (cosine −0.3 > reversal_cosine, a change of direction) that contracts slowly.
  EXPECT_EQ(trust_update({.cosine = -0.9, .length_ratio = 0.4}, 5.0, radius, damping),
            TrustDecision::HOLD);
  EXPECT_EQ(
      trust_update({.cosine = -0.9, .length_ratio = slow_reversal_ratio}, 5.0, radius, damping),
      TrustDecision::HOLD);
  EXPECT_EQ(trust_update({.cosine = -0.3, .length_ratio = contraction_bound}, 5.0, radius, damping),
            TrustDecision::HOLD);
  EXPECT_EQ(radius, 2.0);
  EXPECT_EQ(damping, 1.0);
  // A reversal that contracts slowly (0.7 a step: λ ≈ −0.7): damped, the radius kept; the mode
  // goes to 1 − 0.6 · 1.7 = −0.02.
  EXPECT_EQ(trust_update({.cosine = -0.9, .length_ratio = 0.7}, 5.0, radius, damping),
            TrustDecision::DAMP);
  EXPECT_DOUBLE_EQ(damping, damp_factor);
  // Not clearly shorter (0.97), or longer (1.3, a growing oscillation), same pairs, below the
  // radius: the step's own overshoot; damped, the radius kept, down to min_damping
  // (0.6 → 0.36 → 0.216; 0.13 would be below 0.2).
  EXPECT_EQ(trust_update({.cosine = -0.9, .length_ratio = 0.97}, 5.0, radius, damping),
            TrustDecision::DAMP);
  EXPECT_EQ(trust_update({.cosine = -0.9, .length_ratio = 1.3}, 5.0, radius, damping),
            TrustDecision::DAMP);
  EXPECT_EQ(radius, 2.0);
  EXPECT_NEAR(damping, 0.216, 1e-12);
  // Damped as far as it goes: a reversal that still contracts is held; one that does not halves
  // the radius.
  EXPECT_EQ(trust_update({.cosine = -0.9, .length_ratio = contraction_bound}, 5.0, radius, damping),
            TrustDecision::HOLD);
  EXPECT_EQ(trust_update({.cosine = -0.99, .length_ratio = 1.0}, 5.0, radius, damping),
            TrustDecision::SHRINK);
  EXPECT_EQ(radius, 1.0);
  EXPECT_NEAR(damping, 0.216, 1e-12);
  // A limited step's length is the radius's: however short, it is no sign of contraction, and
  // damping a step the radius cuts changes nothing.
  double fresh = 1.0;
  EXPECT_EQ(
      trust_update({.cosine = -0.9, .length_ratio = 0.5, .limited = true}, 5.0, radius, fresh),
      TrustDecision::SHRINK);
  EXPECT_EQ(radius, 0.5);
  // Nor is a shorter step made with other pairs than the previous one (a pairing flip).
  EXPECT_EQ(trust_update({.cosine = -0.9, .length_ratio = 0.5, .same_pairing = false}, 5.0, radius,
                         fresh),
            TrustDecision::SHRINK);
  EXPECT_EQ(radius, 0.25);
  EXPECT_EQ(fresh, 1.0);
  // A weak turn-back (cosine −0.3 > reversal_cosine) is a change of direction, not a period-2
  // oscillation: halved, not damped.
  EXPECT_EQ(trust_update({.cosine = -0.3, .length_ratio = 1.0}, 5.0, radius, fresh),
            TrustDecision::SHRINK);
  EXPECT_EQ(fresh, 1.0);
  // Right after a DAMP the ratio compares a damped step with an undamped one: held, whatever it
  // reads.
  double r2 = 1.0, damped = damp_factor;
  EXPECT_EQ(
      trust_update({.cosine = -0.95, .length_ratio = 2.0, .same_damping = false}, 5.0, r2, damped),
      TrustDecision::HOLD);
  EXPECT_EQ(r2, 1.0);
  EXPECT_EQ(damped, damp_factor);
}

/// Two parallel straight vessels 6 mm apart along x at y = ±3 mm, z = 10 mm.
core::Skeleton parallel_vessels() {
  core::Skeleton s;
  const int n = 13;
  s.points.resize(2 * n, 3);
  for (int v = 0; v < 2; ++v)
    for (int k = 0; k < n; ++k)
      s.points.row(v * n + k) << -15.0 + 2.5 * k, v == 0 ? -3.0 : 3.0, 10.0;
  for (int v = 0; v < 2; ++v)
    for (int k = 0; k + 1 < n; ++k) s.segments.push_back({v * n + k, v * n + k + 1});
  return s;
}

/// Points midway between the two vessels (y = ±0.05 mm, alternately a hair nearer one or the
/// other), registered with the filter off: each step pulls the paired vessels towards the points,
/// which brings the other vessel nearer to some of them, so the pairing flips back and forth; and
/// once frozen, half the points hold vessel A and half vessel B on one line between them: data
/// that contradict the model (two vessels 6 mm apart cannot both lie on one line).
RegistrationResult register_between_parallel_vessels(double vessel_compliance_ratio = -1.0) {
  Scene s(parallel_vessels());
  IntraopData d;
  const int n = 21;
  d.vessel_points.resize(n, 3);
  for (int k = 0; k < n; ++k)
    d.vessel_points.row(k) << -12.5 + 1.25 * k, (k % 2 ? 0.05 : -0.05), 10.0;
  RegistrationOptions o = loop_options();
  o.global_start.bulk_search.enabled = false;
  o.vessel_filter.max_angle_deg = 90.0;
  o.vessel_filter.one_per_feature = false;
  o.vessel_filter.max_per_tet = 0;
  if (vessel_compliance_ratio >= 0)
    o.step.compliance_ratio[static_cast<std::size_t>(ConstraintSet::VESSELS)] =
        vessel_compliance_ratio;
  return register_model(*s.model, d, o);
}

TEST(RegistrationLoop, APairingThatCyclesIsFrozen) {
  const RegistrationResult r = register_between_parallel_vessels();
  ASSERT_TRUE(r.positions.allFinite());
  // The first FROZEN iteration follows one whose pairing changed back to an earlier set; from
  // there on every iteration keeps the frozen pairs.
  std::size_t first = r.history.size();
  for (std::size_t i = 0; i < r.history.size(); ++i)
    if (r.history[i].pairing == PairingMode::FROZEN) {
      first = i;
      break;
    }
  ASSERT_LT(first, r.history.size()) << "the pairing never froze: " << r.stop_reason;
  EXPECT_TRUE(r.history[first - 1].pairing_changed);
  for (std::size_t i = first; i < r.history.size(); ++i)
    EXPECT_EQ(r.history[i].pairing, PairingMode::FROZEN);
}

TEST(RegistrationLoop, ContradictoryDataAreDampedToTheirSpringsBalanceAndNotDeformed) {
  // Points midway between two vessels pull the model both ways. Across pairing flips each
  // turn-back halves the radius; once the pairs freeze, the compliant rows' balance is a fixed
  // point, and an oscillation about it that does not contract (the step's own overshoot) is
  // damped instead of raced to a NOT_SETTLING stop (the rule before DAMP; it stopped after 9
  // halvings). Whether such an oscillation appears here depends on the last bits of the solves:
  // with ATLAS one DAMP at iteration 24, with OpenBLAS the pairs freeze earlier and every
  // turn-back contracts (held). So every DAMP that happens is checked, and DAMP itself by the
  // injected growing oscillation below. The noise model (informative here:
  // RegistrationOptions::noise is off) then finds that no deformation predicts held-out vessels
  // best.
  const RegistrationResult r = register_between_parallel_vessels();
  ASSERT_TRUE(r.positions.allFinite());
  int halvings = 0, damps = 0;
  for (std::size_t i = 1; i < r.history.size(); ++i) {
    const IterationRecord& before = r.history[i - 1];
    if (before.trust == TrustDecision::SHRINK) {
      EXPECT_NEAR(r.history[i].trust_radius_mm, 0.5 * before.trust_radius_mm, 1e-12)
          << "iteration " << i + 1;
      ++halvings;
    }
    if (before.trust == TrustDecision::DAMP) {
      EXPECT_NEAR(r.history[i].damping, damp_factor * before.damping, 1e-12);
      EXPECT_EQ(r.history[i].trust_radius_mm, before.trust_radius_mm);
      ++damps;
    }
    // Damped for the rest of the stage: the damping changes only by a DAMP.
    if (r.history[i].stage == before.stage && before.trust != TrustDecision::DAMP) {
      EXPECT_EQ(r.history[i].damping, before.damping) << "iteration " << i + 1;
    }
  }
  EXPECT_GE(halvings, 3);
  std::cout << "[ loop ] " << halvings << " halvings, " << damps << " damped; " << r.stop_reason
            << "\n";
  EXPECT_EQ(r.history.back().pairing, PairingMode::FROZEN);
  EXPECT_EQ(r.stop, RegistrationStop::CONVERGED) << r.stop_reason;
  ASSERT_TRUE(r.noise.valid);
  EXPECT_TRUE(r.noise.keep_start) << r.noise.message;
  // The balance is bounded by the data: no node moves farther than the vessels' spacing (6 mm;
  // measured 4.7 mm), the bound a diverging or racing iteration would break.
  EXPECT_LT(r.displacement.rowwise().norm().maxCoeff(), 6.0);
}

TEST(RegistrationLoop, AContractingOscillationKeepsItsRadiusAndConverges) {
  // issue 14 item 4: steps that turn back every time but shrink steadily converge; the old rule
  // halved the radius on each turn-back and raced them to NOT_SETTLING. Fault injection: the
  // free node farthest from the vessels (so the pairing does not feel it) is pushed by
  // p_k = a (-q)^k along z after step k. Each static step removes the last push (the node has no
  // data to hold it), so that node's increment is p_k - p_{k-1}: alternating in sign, 0.7 times
  // the previous one (between the old rule's 0.5 and contraction_bound's 0.9), from 3.4 mm.
  FarNodeInjection c;
  auto& [s, d, o, clean, node, farthest] = c;
  ASSERT_TRUE(clean.converged) << clean.stop_reason;
  ASSERT_GE(node, 0);
  const MatrixX3d& rest = s.mesh.nodes();
  const double a = 2.0, q = 0.7;
  MatrixX3d x_before = rest;  // the positions each step starts from
  int k = 0;
  o.inspect_step = [&](StepResult& step) {
    step.x(node, 2) += a * std::pow(-q, ++k);
    step.max_increment = (step.x - x_before).rowwise().norm().maxCoeff();
    x_before = step.x;
  };
  const RegistrationResult r = register_model(*s.model, d, o);
  int holds = 0, turn_backs_shrunk = 0;
  for (const IterationRecord& h : r.history) {
    holds += h.trust == TrustDecision::HOLD;
    turn_backs_shrunk += h.trust == TrustDecision::SHRINK;
  }
  const double off_clean = (r.positions - clean.positions).rowwise().norm().maxCoeff();
  std::cout << "[ loop ] node " << node << " (" << farthest
            << " mm from the vessels): " << r.iterations << " iterations (clean "
            << clean.iterations << "), " << holds << " held, " << turn_backs_shrunk
            << " shrunk; max |x - x_clean| " << off_clean << " mm; " << r.stop_reason << "\n";
  EXPECT_EQ(r.stop, RegistrationStop::CONVERGED) << r.stop_reason;
  EXPECT_TRUE(r.converged);
  // The oscillation was seen and held: from 3.4 mm at 0.7 a step it takes ≈ 17 steps to fall
  // below the 0.01 mm tolerance, each a turn-back; at least 10 of them held.
  EXPECT_GE(holds, 10);
  // And the answer is the clean one. Stopped at a step below 0.01 mm that contracts by 0.7, the
  // push left is at most 0.01 · 0.7 / (1 − 0.7) ≈ 0.023 mm from the fixed point; 0.05 mm leaves
  // room for the clean run's own stop (also below 0.01 mm a step).
  EXPECT_LT(off_clean, 0.05);
}

/// Fault injection: `node` overshoots every step it takes by `beta` of it, so about its
/// equilibrium e its error maps as (x − e) ← (1 − α (1 + β)) (x − e) under damping α.
std::function<void(StepResult&)> overshoot(const Scene& s, index_t node, double beta) {
  return [node, beta, x_before = MatrixX3d(s.mesh.nodes())](StepResult& step) mutable {
    const Eigen::RowVector3d taken = step.x.row(node) - x_before.row(node);
    step.x.row(node) += beta * taken;
    step.max_increment = (step.x - x_before).rowwise().norm().maxCoeff();
    x_before = step.x;
  };
}

/// How many of a run's iterations the trust region answered with `decision`.
int decisions(const RegistrationResult& r, TrustDecision decision) {
  return static_cast<int>(
      std::count_if(r.history.begin(), r.history.end(),
                    [&](const IterationRecord& h) { return h.trust == decision; }));
}

TEST(RegistrationLoop, AGrowingOscillationBelowTheRadiusIsDampedAndConverges) {
  // issue 14 item 4 (the ICBM152 pre-dura case): an iteration whose map has an eigenvalue of
  // −1.05 turns back every step by a little more than the step before, below the trust radius,
  // which halving cannot reach until it binds. Fault injection: the free node farthest from the
  // vessels overshoots every step it takes by β = 1.05 of it, so about its equilibrium e the
  // node's error maps as (x − e) ← (1 − α (1 + β)) (x − e): −1.05 undamped (α = 1), −0.23 once
  // damped (α = 0.6). The step taken is zero at the fixed point, so the clean answer stays it.
  FarNodeInjection c;
  auto& [s, d, o, clean, node, farthest] = c;
  ASSERT_TRUE(clean.converged) << clean.stop_reason;
  ASSERT_GE(node, 0);
  o.inspect_step = overshoot(s, node, 1.05);
  const RegistrationResult r = register_model(*s.model, d, o);
  const int damps = decisions(r, TrustDecision::DAMP);
  const double off_clean = (r.positions - clean.positions).rowwise().norm().maxCoeff();
  std::cout << "[ loop ] node " << node << " (" << farthest
            << " mm from the vessels): " << r.iterations << " iterations (clean "
            << clean.iterations << "), " << damps << " damped, final damping "
            << r.history.back().damping << "; max |x - x_clean| " << off_clean << " mm; "
            << r.stop_reason << "\n";
  EXPECT_EQ(r.stop, RegistrationStop::CONVERGED) << r.stop_reason;
  EXPECT_GE(damps, 1);
  EXPECT_LT(r.history.back().damping, 1.0);
  // The answer is the clean one: stopped at a step below 0.01 mm × α that contracts by 0.23 (or
  // faster, after a second DAMP), the node is ≈ 0.003 mm from e; 0.05 mm leaves room for the
  // clean run's own stop, as above.
  EXPECT_LT(off_clean, 0.05);
}

TEST(RegistrationLoop, ASlowlyContractingOscillationIsDampedAndSettlesSoon) {
  // The ICBM152 pre-dura SMOOTH stage's tail: every step turns back at about 0.7 of the one
  // before. Fault injection as above with β = 0.7: the far node's error maps as (x − e) ←
  // (1 − α (1 + β)) (x − e), −0.7 undamped, −0.02 once damped (α = 0.6). Here the turn-backs
  // show from 0.08 mm a step (the node's larger steps go with the whole field's), and held at
  // 0.67-0.69 a step they take 11 iterations to settle against the clean run's 6; damped at the
  // second such step, 9. Asked: at least one DAMP, at most 4 iterations more than the clean run,
  // and the clean answer (the stop leaves ≤ 0.01 mm × 0.02 / 0.98 of the mode; 0.05 mm leaves
  // room for the clean run's own stop, as above).
  FarNodeInjection c;
  auto& [s, d, o, clean, node, farthest] = c;
  ASSERT_TRUE(clean.converged) << clean.stop_reason;
  ASSERT_GE(node, 0);
  o.inspect_step = overshoot(s, node, 0.7);
  const RegistrationResult r = register_model(*s.model, d, o);
  const int damps = decisions(r, TrustDecision::DAMP);
  const double off_clean = (r.positions - clean.positions).rowwise().norm().maxCoeff();
  std::cout << "[ loop ] node " << node << ": " << r.iterations << " iterations (clean "
            << clean.iterations << "), " << damps << " damped, final damping "
            << r.history.back().damping << "; max |x - x_clean| " << off_clean << " mm; "
            << r.stop_reason << "\n";
  EXPECT_EQ(r.stop, RegistrationStop::CONVERGED) << r.stop_reason;
  EXPECT_GE(damps, 1);
  EXPECT_LE(r.iterations, clean.iterations + 4);
  EXPECT_LT(off_clean, 0.05);
}

TEST(RegistrationLoop, AnOscillationNothingDampsEndsNotSettlingBeforeTheIterationCap) {
  // A node pushed ±a after every step, whatever the step (fault injection after the trust limit
  // and DAMP's share): every step turns back by 2a, DAMP cannot shrink it, so the radius halves
  // on each turn-back until it is below the increment tolerance, and the stage must end
  // NOT_SETTLING with its diagnosis, not run on to the iteration cap.
  FarNodeInjection c;
  auto& [s, d, o, clean, node, farthest] = c;
  ASSERT_TRUE(clean.converged) << clean.stop_reason;
  ASSERT_GE(node, 0);
  // 1 mm: far above the 0.01 mm tolerance, so no step is ever "small"; pushed at every step.
  o.inspect_step = push_back_and_forth(s, node, 1.0, std::numeric_limits<int>::max());
  const RegistrationResult r = register_model(*s.model, d, o);
  int shrinks = 0;
  for (const IterationRecord& h : r.history) shrinks += h.trust == TrustDecision::SHRINK;
  std::cout << "[ loop ] " << r.iterations << " iterations, " << shrinks << " shrunk; "
            << r.stop_reason << "\n";
  EXPECT_EQ(r.stop, RegistrationStop::NOT_SETTLING) << r.stop_reason;
  EXPECT_FALSE(r.converged);
  // From the default radius to below 0.01 mm takes about ten halvings; the cap is far above.
  EXPECT_GE(shrinks, 5);
  EXPECT_LT(r.iterations, o.max_iterations);
  EXPECT_TRUE(r.positions.allFinite());
  // The stop reason says where it did not settle: the pushed node (its 2 mm turn-back is the
  // last step's largest by far: the other nodes' steps are cut to the collapsed radius).
  EXPECT_EQ(r.history.back().max_increment_node, node);
  EXPECT_NE(r.stop_reason.find("largest at node " + std::to_string(node) + " "), std::string::npos)
      << r.stop_reason;
  EXPECT_LT(r.history.back().increment_beyond_mm, r.history.back().max_increment_mm);
}

TEST(RegistrationLoop, LocateIncrementNamesTheNodeItsShareAndTheMotionBeyondItsElements) {
  // Two tetrahedra sharing the face (1, 2, 3); node 4 shares no element with node 0. A step of
  // (3, 4, 0) mm at node 0, (0, 2, 0) mm at its neighbour 1 and (0, 0, 1) mm at node 4: by hand,
  // node 0 (length 5), share 25 / 30, and beyond node 0's elements node 4's 1 mm (node 1's 2 mm
  // is within them). Exact up to round-off (1e-12).
  MatrixX3d x(5, 3);
  x << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1;
  MatrixX4i tets(2, 4);
  tets << 0, 1, 2, 3, 1, 2, 3, 4;
  const core::TetMesh mesh(x, tets);
  MatrixX3d dx = MatrixX3d::Zero(5, 3);
  dx.row(0) << 3, 4, 0;
  dx.row(1) << 0, 2, 0;
  dx.row(4) << 0, 0, 1;
  IterationRecord rec;
  locate_increment(mesh, dx, x + dx, rec);
  EXPECT_EQ(rec.max_increment_node, 0);
  EXPECT_NEAR((rec.max_increment_at - Vector3d(3, 4, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(rec.max_increment_share, 25.0 / 30.0, 1e-12);
  EXPECT_NEAR(rec.increment_beyond_mm, 1.0, 1e-12);
  EXPECT_NE(describe_increment(rec).find("largest at node 0 ((3.0, 4.0, 0.0) mm, 83 %"),
            std::string::npos)
      << describe_increment(rec);
  // The largest step at node 4 instead: node 0 shares no element with it, its 5 mm is beyond.
  dx.row(4) << 0, 0, 6;
  locate_increment(mesh, dx, x + dx, rec);
  EXPECT_EQ(rec.max_increment_node, 4);
  EXPECT_NEAR(rec.increment_beyond_mm, 5.0, 1e-12);  // node 0 shares no element with node 4
  // No step: no node, and no clause in a stop reason.
  locate_increment(mesh, MatrixX3d::Zero(5, 3), x, rec);
  EXPECT_EQ(rec.max_increment_node, -1);
  EXPECT_EQ(describe_increment(rec), "");
}

TEST(RegistrationLoop, AFreeStageThatDoesNotSettleStillGetsTheNoiseModel) {
  // The FREE stage made to end NOT_SETTLING by the injection above, for exactly the iterations it
  // takes to collapse the radius; the steps after it are clean. The default vessel compliance is a
  // prior: the noise model must still run on the FREE stage's last system, and what it chooses
  // (the start kept, or a SMOOTH stage that settles) ends the registration converged, the stop
  // reason saying that the free stage did not settle. (At 20,841 nodes the default compliance
  // pulls one small element through itself next to a vessel branch and the FREE stage ends
  // NOT_SETTLING in the same way; the data's compliance settles there.)
  FarNodeInjection c;
  auto& [s, d, o, clean, node, farthest] = c;
  ASSERT_GE(node, 0);
  o.inspect_step = push_back_and_forth(s, node, 1.0, std::numeric_limits<int>::max());
  const RegistrationResult stuck = register_model(*s.model, d, o);
  ASSERT_EQ(stuck.stop, RegistrationStop::NOT_SETTLING) << stuck.stop_reason;
  const int n = stuck.iterations;

  o.noise.enabled = true;
  o.inspect_step = push_back_and_forth(s, node, 1.0, n);
  const RegistrationResult r = register_model(*s.model, d, o);
  std::cout << "[ loop ] " << r.stop_reason << "\n";
  ASSERT_FALSE(r.stages.empty());
  EXPECT_EQ(r.stages[0].kind, StageKind::FREE);
  EXPECT_EQ(r.stages[0].stop, StageStop::NOT_SETTLING);
  EXPECT_EQ(r.stages[0].iterations, n);
  EXPECT_TRUE(r.noise.valid) << r.stop_reason;
  ASSERT_GE(r.stages.size(), 2U);
  EXPECT_EQ(r.stages.back().kind, StageKind::SMOOTH);
  EXPECT_TRUE(r.converged) << r.stop_reason;
  EXPECT_NE(r.stop_reason.find("the free stage ended not_settling"), std::string::npos)
      << r.stop_reason;
  EXPECT_TRUE(r.positions.allFinite());
}

/// The successive-steps record of two increments as the loop makes it (cosine, max-nodal
/// length ratio, projection), for the same pairs and damping, neither limited.
SuccessiveSteps successive(const Eigen::VectorXd& previous, const Eigen::VectorXd& current) {
  SuccessiveSteps s;
  s.cosine = current.dot(previous) / (current.norm() * previous.norm());
  s.length_ratio = current.cwiseAbs().maxCoeff() / previous.cwiseAbs().maxCoeff();
  s.projected_ratio = current.dot(previous) / previous.squaredNorm();
  return s;
}

TEST(RegistrationLoop, ATailJumpLandsOnTheFixedPointOfAContractingMap) {
  // Closed form: the affine map x ← x* + A (x − x*) with A = ρ (I + 0.05 N), N a fixed symmetric
  // matrix of unit norm, is a contraction with eigenvalues ρ(1 ± 0.05 ...): one rate, nearly.
  // Its fixed point x* is known; from any x₀, the jump after two steps whose ratios agree must
  // land much nearer to x* than the plain iterate, for a monotone (ρ > 0) and an oscillating
  // (ρ < 0) tail, and exactly on it when A = ρ I (Aitken's Δ² is exact for one geometric mode).
  const int n = 12;
  Eigen::MatrixXd N = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i + 1 < n; ++i) N(i, i + 1) = N(i + 1, i) = 0.5;
  const Eigen::VectorXd x_star = Eigen::VectorXd::LinSpaced(n, -3.0, 4.0);
  Eigen::VectorXd x0(n);
  for (int i = 0; i < n; ++i) x0(i) = std::sin(1.3 * i) + 0.2;
  for (const double rho : {0.8, 0.5, -0.7}) {
    for (const double spread : {0.0, 0.05}) {
      const Eigen::MatrixXd A = rho * (Eigen::MatrixXd::Identity(n, n) + spread * N);
      const auto G = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
        return x_star + A * (x - x_star);
      };
      const Eigen::VectorXd x1 = G(x0), x2 = G(x1), x3 = G(x2);
      const SuccessiveSteps s12 = successive(x1 - x0, x2 - x1);
      const SuccessiveSteps s23 = successive(x2 - x1, x3 - x2);
      const std::optional<double> f = tail_jump_factor(tail_ratio(s12), tail_ratio(s23));
      ASSERT_TRUE(f.has_value()) << "rho " << rho << " spread " << spread;
      const Eigen::VectorXd jumped = x3 + *f * (x3 - x2);
      const double plain = (x3 - x_star).norm(), after = (jumped - x_star).norm();
      std::cout << "[ tail ] rho " << rho << " spread " << spread << ": |x3 - x*| " << plain
                << ", after the jump " << after << "\n";
      if (spread == 0.0)
        EXPECT_LT(after, 1e-12 * x_star.norm());  // exact up to round-off
      else
        // Mode j of rate ρⱼ keeps |1 − f (1 − ρⱼ) / ρⱼ| of its distance, f the jump's factor:
        // ≤ 0.27 for ρⱼ within ±5 % of 0.8, less for 0.5 and −0.7.
        EXPECT_LT(after, 0.3 * plain);
    }
  }
}

TEST(RegistrationLoop, ATailJumpNeedsTwoAgreeingContractingSteps) {
  // The rule's refusals, each against the condition it protects.
  SuccessiveSteps ok;
  ok.cosine = 0.95;
  ok.length_ratio = ok.projected_ratio = 0.6;
  ASSERT_TRUE(tail_ratio(ok).has_value());
  EXPECT_NEAR(*tail_jump_factor(0.62, 0.6), 0.6 / 0.4, 1e-15);
  // Ratios that disagree (a transient, not a mode) or change sign: no jump.
  EXPECT_FALSE(tail_jump_factor(0.45, 0.6).has_value());
  EXPECT_FALSE(tail_jump_factor(-0.6, 0.6).has_value());
  EXPECT_FALSE(tail_jump_factor(std::nullopt, 0.6).has_value());
  // Steps of another map (new pairs, a DAMP between them), a step cut to the radius, a stage's
  // first step, a turn across the 45° cone, a step that does not contract: no ratio.
  for (const auto& spoil : std::vector<std::function<void(SuccessiveSteps&)>>{
           [](SuccessiveSteps& s) { s.same_pairing = false; },
           [](SuccessiveSteps& s) { s.same_damping = false; },
           [](SuccessiveSteps& s) { s.limited = true; },
           [](SuccessiveSteps& s) { s.cosine.reset(); }, [](SuccessiveSteps& s) { s.cosine = 0.5; },
           [](SuccessiveSteps& s) { s.projected_ratio = 0.95; }}) {
    SuccessiveSteps s = ok;
    spoil(s);
    EXPECT_FALSE(tail_ratio(s).has_value());
  }
}

}  // namespace
}  // namespace brainshift::constraints
