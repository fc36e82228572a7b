#include "constraints/registration/uncertainty/uncertainty.hpp"

#include "constraints/registration/noise/vessel_blocks.hpp"
#include "core/error.hpp"
#include "core/solver/nodal_rotations.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <map>
#include <tuple>

namespace brainshift::constraints {
namespace {

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// The coarse set: per grid cell of `spacing` (mm), the free node nearest the cell's centre of
/// its free nodes; plus every node flagged in `always`.
std::vector<index_t> coarse_nodes(const core::DofMap& dofs, ConstRef<MatrixX3d> nodes,
                                  double spacing, const std::vector<bool>& always,
                                  const std::vector<bool>& known) {
  const index_t n = nodes.rows();
  std::vector<index_t> out;
  auto wanted = [&](index_t i) {
    return !dofs.is_fixed_node(i) && !known[static_cast<std::size_t>(i)];
  };
  if (!(spacing > 0)) {
    for (index_t i = 0; i < n; ++i)
      if (wanted(i)) out.push_back(i);
    return out;
  }
  const Vector3d lo = nodes.colwise().minCoeff().transpose();
  std::map<std::tuple<long, long, long>, std::vector<index_t>> cells;
  for (index_t i = 0; i < n; ++i) {
    if (dofs.is_fixed_node(i)) continue;
    const Vector3d c = ((nodes.row(i).transpose() - lo) / spacing).array().floor();
    cells[{static_cast<long>(c[0]), static_cast<long>(c[1]), static_cast<long>(c[2])}].push_back(i);
  }
  std::vector<bool> chosen(static_cast<std::size_t>(n), false);
  for (const auto& [key, members] : cells) {
    if (std::any_of(members.begin(), members.end(),
                    [&](index_t i) { return known[static_cast<std::size_t>(i)]; }))
      continue;  // the cell has an exact value already
    Vector3d centre = Vector3d::Zero();
    for (index_t i : members) centre += nodes.row(i).transpose();
    centre /= static_cast<double>(members.size());
    index_t best = members.front();
    double best_d = 1e300;
    for (index_t i : members)
      if (const double d = (nodes.row(i).transpose() - centre).squaredNorm(); d < best_d) {
        best_d = d;
        best = i;
      }
    chosen[static_cast<std::size_t>(best)] = true;
  }
  for (index_t i = 0; i < n; ++i)
    if ((chosen[static_cast<std::size_t>(i)] || always[static_cast<std::size_t>(i)]) && wanted(i))
      out.push_back(i);
  return out;
}

/// Pseudo-inverse of a small symmetric positive semi-definite matrix (eigenvalues below 1e-10 ×
/// the largest dropped) and its rank.
Eigen::MatrixXd pseudo_inverse(const Eigen::MatrixXd& a, index_t& rank) {
  rank = 0;
  if (a.rows() == 0) return a;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (a + a.transpose()));
  const Eigen::VectorXd& l = es.eigenvalues();
  const double top = l.maxCoeff();
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(l.size());
  if (std::isfinite(top) && top > 0)
    for (Eigen::Index i = 0; i < l.size(); ++i)
      if (l[i] > 1e-10 * top) inv[i] = 1.0 / l[i], ++rank;
  return es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
}

Matrix3d cross_matrix(const Vector3d& v) {
  Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// nodal_variance's argument checks.
void verify_nodal_inputs(const core::DofMap& dofs, index_t n, index_t f, const SparseMatrix& G,
                         const Eigen::VectorXd& noise, const NodalVarianceExtras& extras) {
  BS_VERIFY(dofs.num_full() == 3 * n,
            "uncertainty: " << n << " nodes for a DOF map of " << dofs.num_full() << " DOFs");
  BS_VERIFY(G.rows() == f && G.cols() == noise.size(),
            "uncertainty: data rows " << G.rows() << "×" << G.cols() << " for " << f
                                      << " free DOFs and " << noise.size() << " noise entries");
  BS_VERIFY(noise.size() == 0 || (noise.array() > 0).all(), "uncertainty: row noise must be > 0");
  BS_VERIFY(
      !extras.known_prior || extras.known_prior->size() == n,
      "uncertainty: " << extras.known_prior->size() << " known prior traces for " << n << " nodes");
  BS_VERIFY(
      !extras.delta || extras.delta->size() == noise.size(),
      "uncertainty: " << extras.delta->size() << " row values for " << noise.size() << " rows");
}

/// The rigid pose as an unknown with a flat prior (universal kriging): M = Grᵀ S⁻¹ Gr, and the
/// node's rigid term tr(R_n M⁺ R_nᵀ), R_n = h_n − Rot_n (K0⁻¹ G S⁻¹ Gr)_n; S⁻¹ Gr and M⁺ out.
void rigid_term(const core::DofMap& dofs, index_t n, const SparseMatrix& G,
                const Eigen::MatrixXd& Y, const Eigen::LLT<Eigen::MatrixXd>& llt,
                const NodalVarianceExtras& extras, NodalVariance& out, Eigen::MatrixXd& SiGr,
                Eigen::MatrixXd& Mp) {
  const Eigen::MatrixXd& Gr = *extras.rigid_rows;
  BS_VERIFY(Gr.rows() == G.cols() && Gr.cols() == 6, "uncertainty: rigid rows "
                                                         << Gr.rows() << "×" << Gr.cols() << " for "
                                                         << G.cols() << " rows (expected ×6)");
  BS_VERIFY(extras.rigid_points && extras.rigid_points->rows() == n,
            "uncertainty: the rigid term needs " << n << " node positions");
  BS_VERIFY(!extras.node_rotations || extras.node_rotations->size() == std::size_t(n),
            "uncertainty: " << extras.node_rotations->size() << " rotations for " << n << " nodes");
  SiGr = llt.solve(Gr);
  Mp = pseudo_inverse(Gr.transpose() * SiGr, out.rigid_rank);
  const Eigen::MatrixXd Q = Y * SiGr;  // f×6
  out.rigid = Eigen::VectorXd::Zero(n);
  for (index_t i = 0; i < n; ++i) {
    Eigen::Matrix<double, 3, 6> h;
    h.leftCols<3>().setIdentity();
    h.rightCols<3>() = -cross_matrix(extras.rigid_points->row(i).transpose() - extras.rigid_centre);
    Eigen::Matrix<double, 3, 6> q = Eigen::Matrix<double, 3, 6>::Zero();
    for (int c = 0; c < 3; ++c)
      if (const index_t fi = dofs.free_index(3 * i + c); fi >= 0) q.row(c) = Q.row(fi);
    const Eigen::Matrix<double, 3, 6> rm =
        h -
        (extras.node_rotations ? (*extras.node_rotations)[std::size_t(i)] : Matrix3d::Identity()) *
            q;
    out.rigid[i] = std::max(0.0, (rm * Mp * rm.transpose()).trace());
  }
}

/// The likelihood of the rows' values δ: δᵀ (W + A)⁻¹ δ, the fitted residual against its
/// expectation, the restricted form and the held-out blocks' closed form.
void likelihood_terms(const Eigen::MatrixXd& S, const Eigen::LLT<Eigen::MatrixXd>& llt,
                      const SparseMatrix& G, const Eigen::VectorXd& noise,
                      const NodalVarianceExtras& extras, const Eigen::MatrixXd& SiGr,
                      const Eigen::MatrixXd& Mp, NodalVariance& out) {
  // ML: δᵀ (W + A)⁻¹ δ. Discrepancy: the fitted rows' residual r = A (W + A)⁻¹ δ against its
  // expectation E‖r‖² = s² tr(A (W + A)⁻¹ A).
  const Eigen::VectorXd a = extras.noise_relative ? Eigen::VectorXd(out.scale * noise) : noise;
  const Eigen::VectorXd w = llt.solve(*extras.delta);
  out.quadratic = extras.delta->dot(w);
  out.residual_sq = (a.array() * w.array()).matrix().squaredNorm();
  const Eigen::MatrixXd Sinv = llt.solve(Eigen::MatrixXd::Identity(S.rows(), S.cols()));
  out.residual_dof = (a.array().square() * Sinv.diagonal().array()).sum();
  // Restricted (rigid pose projected out) and held-out-block forms: P = S⁻¹ − S⁻¹Gr M⁺ GrᵀS⁻¹,
  // Pδ ~ N(0, s² P), so each block's w_bᵀ (P_bb)⁺ w_b ~ s² χ²(rank P_bb): the closed form of
  // the residuals at blocks held out of the linear-Gaussian fit.
  Eigen::VectorXd pw = w;
  Eigen::MatrixXd P = Sinv;
  if (extras.rigid_rows) {
    pw -= SiGr * (Mp * (SiGr.transpose() * *extras.delta));
    P -= SiGr * Mp * SiGr.transpose();
  }
  out.restricted_quadratic = extras.delta->dot(pw);
  if (extras.blocks) {
    BS_VERIFY(extras.blocks->size() == std::size_t(G.cols()),
              "uncertainty: " << extras.blocks->size() << " block ids for " << G.cols() << " rows");
    std::map<index_t, std::vector<index_t>> members;
    for (index_t j = 0; j < G.cols(); ++j)
      if ((*extras.blocks)[std::size_t(j)] >= 0)
        members[(*extras.blocks)[std::size_t(j)]].push_back(j);
    for (const auto& [id, rows] : members) {
      const auto k = static_cast<Eigen::Index>(rows.size());
      Eigen::MatrixXd pb(k, k);
      Eigen::VectorXd wb(k);
      for (Eigen::Index a1 = 0; a1 < k; ++a1) {
        wb[a1] = pw[rows[std::size_t(a1)]];
        for (Eigen::Index a2 = 0; a2 < k; ++a2)
          pb(a1, a2) = P(rows[std::size_t(a1)], rows[std::size_t(a2)]);
      }
      index_t rank = 0;
      const Eigen::MatrixXd pinv = pseudo_inverse(pb, rank);
      if (rank == 0) continue;
      out.heldout_quadratic += wb.dot(pinv * wb);
      out.heldout_rows += static_cast<double>(rank);
      ++out.heldout_blocks;
    }
  }
}

/// The prior term: exact at the coarse nodes (unit-load solves, in blocks) and where
/// extras.known_prior gives it, interpolated elsewhere.
void prior_term(const core::CholmodFactor& factor, const core::DofMap& dofs,
                ConstRef<MatrixX3d> nodes, const UncertaintyOptions& options,
                const NodalVarianceExtras& extras, const std::vector<bool>& touched,
                NodalVariance& out) {
  const index_t n = nodes.rows();
  const index_t f = dofs.num_free();
  // Prior term: exact on the coarse set by unit loads (‖L⁻¹ P eᵢ‖² = (K0⁻¹)ᵢᵢ), in blocks.
  std::vector<bool> exact(static_cast<std::size_t>(n), false);
  std::vector<index_t> known;  // from extras.known_prior: exact without a solve
  if (extras.known_prior)
    for (index_t i = 0; i < n; ++i)
      if ((*extras.known_prior)[i] >= 0 && !dofs.is_fixed_node(i)) {
        out.prior[i] = (*extras.known_prior)[i];
        exact[static_cast<std::size_t>(i)] = true;
        known.push_back(i);
      }
  std::vector<index_t> coarse =
      coarse_nodes(dofs, nodes, options.coarse_spacing_mm, touched, exact);
  out.solved_nodes = static_cast<index_t>(coarse.size());
  const std::size_t block = static_cast<std::size_t>(options.solve_block);
  for (std::size_t b0 = 0; b0 < coarse.size(); b0 += block) {
    const std::size_t b1 = std::min(coarse.size(), b0 + block);
    std::vector<Eigen::Triplet<double>> t;
    std::vector<index_t> col_node;
    for (std::size_t j = b0; j < b1; ++j)
      for (int c = 0; c < 3; ++c) {
        const index_t fi = dofs.free_index(3 * coarse[j] + c);
        if (fi < 0) continue;
        t.emplace_back(fi, static_cast<index_t>(col_node.size()), 1.0);
        col_node.push_back(coarse[j]);
      }
    SparseMatrix E(f, static_cast<index_t>(col_node.size()));
    E.setFromTriplets(t.begin(), t.end());
    const SparseMatrix L = factor.solve_lower_permuted(E);
    for (int k = 0; k < L.outerSize(); ++k) {
      double s = 0.0;
      for (SparseMatrix::InnerIterator it(L, k); it; ++it) s += it.value() * it.value();
      out.prior[col_node[static_cast<std::size_t>(k)]] += s;
    }
    for (std::size_t j = b0; j < b1; ++j) exact[static_cast<std::size_t>(coarse[j])] = true;
  }
  coarse.insert(coarse.end(), known.begin(), known.end());
  out.exact_nodes = static_cast<index_t>(coarse.size());
  // Elsewhere: inverse-distance weighting (1/d²) of the 4 nearest coarse nodes.
  if (!coarse.empty())
    for (index_t i = 0; i < n; ++i) {
      if (exact[static_cast<std::size_t>(i)] || dofs.is_fixed_node(i)) continue;
      std::array<std::pair<double, index_t>, 4> best;
      best.fill({1e300, -1});
      for (index_t c : coarse) {
        const double d = (nodes.row(c) - nodes.row(i)).squaredNorm();
        if (d < best[3].first) {
          best[3] = {d, c};
          std::sort(best.begin(), best.end());
        }
      }
      double wsum = 0.0, v = 0.0;
      for (const auto& [d, c] : best)
        if (c >= 0) {
          const double w = 1.0 / std::max(d, 1e-12);
          wsum += w;
          v += w * out.prior[c];
        }
      out.prior[i] = wsum > 0 ? v / wsum : 0.0;
    }
}

}  // namespace

NodalVariance nodal_variance(const core::CholmodFactor& factor, const core::DofMap& dofs,
                             ConstRef<MatrixX3d> nodes, const SparseMatrix& G,
                             const Eigen::VectorXd& noise, const UncertaintyOptions& options,
                             const NodalVarianceExtras& extras) {
  const std::string invalid = options.validate();
  BS_VERIFY(invalid.empty(), invalid);
  const index_t n = nodes.rows();
  const index_t f = dofs.num_free();
  verify_nodal_inputs(dofs, n, f, G, noise, extras);
  NodalVariance out;
  out.prior = Eigen::VectorXd::Zero(n);
  out.posterior = Eigen::VectorXd::Zero(n);
  out.rigid = Eigen::VectorXd::Zero(n);

  // Data term per DOF: column norms² of L⁻¹ Yᵀ, Y = K0⁻¹ G, L the Cholesky factor of W + A.
  Eigen::VectorXd reduction = Eigen::VectorXd::Zero(f);
  std::vector<bool> touched(static_cast<std::size_t>(n), false);
  if (G.cols() > 0) {
    const Eigen::MatrixXd Y = factor.solve(Eigen::MatrixXd(G));
    Eigen::MatrixXd S = Eigen::MatrixXd(G.transpose() * Y);
    S = 0.5 * (S + S.transpose()).eval();
    const Eigen::VectorXd d = S.diagonal();  // (a Diagonal's data() is strided)
    const std::vector<double> diag(d.data(), d.data() + d.size());
    out.scale = median_of(diag);
    S.diagonal() += extras.noise_relative ? Eigen::VectorXd(out.scale * noise) : noise;
    const Eigen::LLT<Eigen::MatrixXd> llt(S);
    BS_VERIFY(llt.info() == Eigen::Success,
              "uncertainty: the data rows' covariance is not positive definite");
    Eigen::MatrixXd SiGr, Mp;  // the rigid term's S⁻¹ Gr and M⁺
    if (extras.rigid_rows) rigid_term(dofs, n, G, Y, llt, extras, out, SiGr, Mp);
    if (extras.delta) likelihood_terms(S, llt, G, noise, extras, SiGr, Mp, out);
    const Eigen::MatrixXd Zt = llt.matrixL().solve(Y.transpose());
    reduction = Zt.colwise().squaredNorm().transpose();
    for (int k = 0; k < G.outerSize(); ++k)
      for (SparseMatrix::InnerIterator it(G, k); it; ++it)
        touched[static_cast<std::size_t>(dofs.full_index(it.row()) / 3)] = true;
  }

  prior_term(factor, dofs, nodes, options, extras, touched, out);
  for (index_t i = 0; i < n; ++i) {
    double red = 0.0;
    for (int c = 0; c < 3; ++c)
      if (const index_t fi = dofs.free_index(3 * i + c); fi >= 0) red += reduction[fi];
    out.posterior[i] = std::max(0.0, out.prior[i] - red);
  }
  return out;
}

UncertaintyResult predict_uncertainty(const RegistrationModel& model, const RegistrationResult& r,
                                      const RegistrationOptions& options) {
  return predict_uncertainty(model, r, options, options.uncertainty);
}

namespace {

/// The data rows in use at the final state (not the dura's, not a separated unilateral row),
/// rotated: G = (H R)ᵀ on the free DOFs; each row's compliance ratio, its rigid sensitivities
/// about the rows' centroid and, for a vessel row, its cross-validation block.
struct UncertaintyRows {
  std::vector<index_t> used;
  SparseMatrix G;
  Eigen::VectorXd ratio;
  Eigen::MatrixXd rigid_rows;
  Vector3d centre = Vector3d::Zero();
  std::vector<index_t> blocks;
};

UncertaintyRows uncertainty_rows(const RegistrationModel& model, const RegistrationResult& r,
                                 const RegistrationOptions& options, const UncertaintyOptions& uo,
                                 const std::vector<Matrix3d>& R) {
  const core::DofMap& dofs = model.mechanics().dofs();
  UncertaintyRows u;
  std::vector<index_t>& used = u.used;
  for (index_t i = 0; i < r.data_rows.size(); ++i) {
    const ConstraintRow& row = r.data_rows[i];
    if (row.set == ConstraintSet::DURA || row.set == ConstraintSet::FIXED) continue;
    if (row.law == ConstraintLaw::UNILATERAL && row.violation > uo.separated_mm) continue;
    used.push_back(i);
  }
  const index_t m = static_cast<index_t>(used.size());
  std::vector<Eigen::Triplet<double>> t;
  Eigen::VectorXd& ratio = u.ratio;
  ratio.resize(m);
  for (index_t j = 0; j < m; ++j) {
    const ConstraintRow& row = r.data_rows[used[static_cast<std::size_t>(j)]];
    for (int k = 0; k < row.stencil.size; ++k) {
      const index_t node = row.stencil.node[static_cast<std::size_t>(k)];
      const Vector3d g = row.stencil.weight[static_cast<std::size_t>(k)] *
                         (R[static_cast<std::size_t>(node)].transpose() * row.direction);
      for (int c = 0; c < 3; ++c)
        if (const index_t fi = dofs.free_index(3 * node + c); fi >= 0) t.emplace_back(fi, j, g[c]);
    }
    const double set_ratio = row.set == ConstraintSet::VESSELS
                                 ? r.vessel_compliance_ratio
                                 : options.step.compliance_ratio[static_cast<std::size_t>(row.set)];
    // ε → ∞ (the loop kept its rigid start: no compliance predicted the held-out vessels better)
    // is read as the stiffest candidate the noise model weighed, so the rows stay finite data
    // that barely condition the prior.
    ratio[j] =
        std::max(std::isfinite(set_ratio) ? set_ratio : options.noise.max_ratio, uo.hard_row_ratio);
  }
  u.G = SparseMatrix(dofs.num_free(), m);
  u.G.setFromTriplets(t.begin(), t.end());
  // The rows' rigid sensitivities about their centroid, and the vessel rows' CV blocks.
  Eigen::MatrixXd& rigid_rows = u.rigid_rows;
  rigid_rows.resize(m, 6);
  Vector3d& centre = u.centre;
  std::vector<Vector3d> at(static_cast<std::size_t>(m));
  for (index_t j = 0; j < m; ++j) {
    at[std::size_t(j)] = r.data_rows[used[std::size_t(j)]].stencil.position(r.positions);
    centre += at[std::size_t(j)] / static_cast<double>(m);
  }
  const std::vector<index_t> segment_block =
      segment_blocks(model.skeleton(), options.noise.block_length_mm);
  std::vector<index_t>& blocks = u.blocks;
  blocks.assign(static_cast<std::size_t>(m), -1);
  for (index_t j = 0; j < m; ++j) {
    const ConstraintRow& row = r.data_rows[used[std::size_t(j)]];
    rigid_rows.row(j).head<3>() = row.direction.transpose();
    rigid_rows.row(j).tail<3>() = (at[std::size_t(j)] - centre).cross(row.direction).transpose();
    if (row.set == ConstraintSet::VESSELS && row.feature >= 0 &&
        static_cast<std::size_t>(row.feature) < segment_block.size())
      blocks[std::size_t(j)] = segment_block[static_cast<std::size_t>(row.feature)];
  }
  return u;
}

/// δ_free: the rows' violation if the model relaxed to its unloaded shape (as the step's).
Eigen::VectorXd free_violations(const ConstrainedModel& mech, const RegistrationResult& r,
                                const RegistrationOptions& options,
                                const core::ElementRotations& er, const std::vector<Matrix3d>& R,
                                const std::vector<index_t>& used) {
  const index_t m = static_cast<index_t>(used.size());
  Eigen::VectorXd delta_free(m);
  if (m > 0) {
    Eigen::VectorXd f = -mech.model().internal_force(r.positions, er.rotation);
    if (!options.step.gravity.isZero())
      f += mech.model().gravity_force(options.step.gravity, options.step.density);
    const Eigen::VectorXd dx = mech.compliance().apply(f, R);
    for (index_t j = 0; j < m; ++j) {
      const ConstraintRow& row = r.data_rows[used[static_cast<std::size_t>(j)]];
      Vector3d p = Vector3d::Zero();
      for (int k = 0; k < row.stencil.size; ++k)
        p += row.stencil.weight[static_cast<std::size_t>(k)] *
             dx.segment<3>(3 * row.stencil.node[static_cast<std::size_t>(k)]);
      delta_free[j] = row.violation + row.direction.dot(p);
    }
  }
  return delta_free;
}

/// s² from the data rows by the chosen estimator, at its upper confidence bound; into `out`,
/// and the sentence that says how (empty when s² could not be estimated).
std::string estimate_scale(const NodalVariance& nv, index_t m, const UncertaintyOptions& uo,
                           bool pose_given, UncertaintyResult& out) {
  const double scale = nv.scale;
  char buf[1000] = "";
  const double md = static_cast<double>(m);
  out.s2_ml = nv.quadratic / md;
  out.s2_discrepancy = nv.residual_sq / std::max(nv.residual_dof, 1e-300);
  out.s2_restricted =
      nv.restricted_quadratic / std::max(1.0, md - static_cast<double>(nv.rigid_rank));
  out.s2_heldout = nv.heldout_rows > 0 ? nv.heldout_quadratic / nv.heldout_rows : 0.0;
  out.heldout_blocks = nv.heldout_blocks;
  out.rigid_rank = nv.rigid_rank;
  using SE = UncertaintyOptions::ScaleEstimator;
  const char* how = "";
  double s2 = 0.0;
  SE estimator = uo.scale_estimator;
  if (estimator == SE::BY_POSE) estimator = pose_given ? SE::HELD_OUT : SE::MAXIMUM_LIKELIHOOD;
  switch (estimator) {
    case SE::DISCREPANCY:
      s2 = out.s2_discrepancy;
      how = "by the discrepancy principle (fitted rows' residual ‖r‖² = s² tr(A (W + A)⁻¹ A))";
      break;
    case SE::MAXIMUM_LIKELIHOOD:
      s2 = out.s2_ml;
      how = "by maximum likelihood (δ_free ~ N(0, s²(W + A)))";
      break;
    case SE::HELD_OUT:
    case SE::BY_POSE:
      s2 = nv.heldout_rows > 0 ? out.s2_heldout : out.s2_restricted;
      how = nv.heldout_rows > 0
                ? "from the residuals at held-out vessel blocks (closed-form leave-one-block-out "
                  "of the linear-Gaussian fit, pose projected out)"
                : "by restricted maximum likelihood (no vessel blocks to hold out)";
      break;
  }
  out.scale_estimator = estimator;
  // The sampling uncertainty of s² with few effectively independent rows: an upper bound.
  out.scale_rows = nv.heldout_blocks > 0 ? static_cast<double>(nv.heldout_blocks) : md;
  out.scale_factor = uo.scale_confidence > 0
                         ? out.scale_rows / chi2_quantile(out.scale_rows, 1.0 - uo.scale_confidence)
                         : 1.0;
  if (s2 > 0 && std::isfinite(s2) && scale > 0 && std::isfinite(out.scale_factor)) {
    out.s2 = uo.calibration * s2 * out.scale_factor;
    out.estimated = true;
    out.noise_sigma_mm = std::sqrt(out.s2 * out.vessel_alpha);
    std::snprintf(
        buf, sizeof buf,
        "s² %s of the %lld data rows, at its %.3g upper confidence bound (χ² with %.0f "
        "effective rows: × %.3g) = %.4g mN·mm%s (maximum likelihood %.4g, %lld blocks "
        "held out); α = the registration's vessel compliance (ratio %.3g × median diag W "
        "%.4g mm/mN), hard rows %.3g × it; implied vessel-row scatter %.3g mm; %s; dura rows "
        "not used",
        how, static_cast<long long>(m), uo.scale_confidence, out.scale_rows, out.scale_factor,
        out.s2, uo.calibration != 1.0 ? " (× calibration)" : "", out.s2_ml,
        static_cast<long long>(out.heldout_blocks), out.vessel_ratio, scale, uo.hard_row_ratio,
        out.noise_sigma_mm,
        uo.rigid_term ? "the pose of the rigid start is an unknown of the model (rigid term)"
                      : "pose taken as known");
  }
  return buf;
}

}  // namespace

UncertaintyResult predict_uncertainty(const RegistrationModel& model, const RegistrationResult& r,
                                      const RegistrationOptions& options,
                                      const UncertaintyOptions& uo) {
  const std::string invalid = uo.validate();
  BS_VERIFY(invalid.empty(), invalid);
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  const ConstrainedModel& mech = model.mechanics();
  const core::TetMesh& mesh = model.mesh();
  const core::DofMap& dofs = mech.dofs();
  const index_t n = mesh.num_nodes();
  BS_VERIFY(
      r.positions.rows() == n && r.positions.allFinite(),
      "uncertainty: the result has " << r.positions.rows() << " positions for " << n << " nodes");
  UncertaintyResult out;

  // The data rows in use at the final state, rotated: G = (H R)ᵀ on the free DOFs.
  const core::ElementRotations er = mech.model().element_rotations(r.positions);
  const std::vector<Matrix3d> R = core::nodal_rotations(mesh, er.rotation);
  const UncertaintyRows u = uncertainty_rows(model, r, options, uo, R);
  const std::vector<index_t>& used = u.used;
  const index_t m = static_cast<index_t>(used.size());
  const SparseMatrix& G = u.G;
  const Eigen::VectorXd& ratio = u.ratio;
  const Eigen::MatrixXd& rigid_rows = u.rigid_rows;
  const Vector3d& centre = u.centre;
  const std::vector<index_t>& blocks = u.blocks;
  out.rows = m;

  const Eigen::VectorXd delta_free = free_violations(mech, r, options, er, R, used);
  // The prior's nodal traces the dense compliance block already holds.
  Eigen::VectorXd known(n);
  for (index_t i = 0; i < n; ++i) known[i] = mech.compliance().block_trace(i);
  const bool usable = m > 0 && delta_free.allFinite();
  NodalVarianceExtras extras;
  extras.known_prior = &known;
  extras.noise_relative = true;
  extras.delta = &delta_free;
  extras.blocks = &blocks;
  if (uo.rigid_term) {
    extras.rigid_rows = &rigid_rows;
    extras.rigid_points = &r.positions;
    extras.rigid_centre = centre;
    extras.node_rotations = &R;
  }
  const NodalVariance nv =
      usable ? nodal_variance(mech.factor(), dofs, mesh.nodes(), G, ratio, uo, extras)
             : nodal_variance(mech.factor(), dofs, mesh.nodes(), SparseMatrix(dofs.num_free(), 0),
                              Eigen::VectorXd(), uo, {&known, false, nullptr});
  const double scale = nv.scale;
  out.exact_nodes = nv.exact_nodes;
  out.solved_nodes = nv.solved_nodes;
  out.vessel_ratio = std::isfinite(r.vessel_compliance_ratio) ? r.vessel_compliance_ratio
                                                              : options.noise.max_ratio;
  out.vessel_alpha = out.vessel_ratio * scale;
  std::string estimation =
      usable ? estimate_scale(nv, m, uo, r.start.pose_given, out) : std::string();
  char buf[1000];
  if (!out.estimated) {
    std::vector<double> free_prior;
    for (index_t i = 0; i < n; ++i)
      if (!dofs.is_fixed_node(i)) free_prior.push_back(nv.prior[i]);
    const double med = median_of(free_prior);
    out.s2 = med > 0 ? uo.no_data_median_mm * uo.no_data_median_mm / med : 0.0;
    std::snprintf(buf, sizeof buf,
                  "no usable data rows (%lld): s² not estimated; the prior alone, scaled to a "
                  "median predicted error "
                  "of %.3g mm",
                  static_cast<long long>(m), uo.no_data_median_mm);
    estimation = buf;
  }
  out.estimation = estimation;
  out.node_posterior = nv.posterior;
  out.node_rigid = nv.rigid;
  out.node_variance =
      out.s2 * (out.estimated ? Eigen::VectorXd(nv.posterior + nv.rigid) : nv.prior);
  // The stated tracking accuracy: a rigid error of the data's frame about the rows' centroid
  // (without rows: the free nodes' centroid), which no row can show; not scaled by s².
  if (m > 0) {
    out.tracking_centre = centre;
  } else {
    index_t k = 0;
    for (index_t i = 0; i < n; ++i)
      if (!dofs.is_fixed_node(i)) out.tracking_centre += r.positions.row(i).transpose(), ++k;
    if (k > 0) out.tracking_centre /= static_cast<double>(k);
  }
  out.node_tracking = tracking_variance(r.positions, out.tracking_centre, uo);
  out.node_variance += out.node_tracking;
  // The pose searched on this sweep (UncertaintyOptions::pose_confounded).
  const bool confounded = uo.pose_confounded && r.start.accepted && m > 0;
  out.node_pose = confounded ? confounded_pose_variance(model, r, used) : Eigen::VectorXd::Zero(n);
  out.node_variance += out.node_pose;
  if (uo.tracking_translation_mm > 0 || uo.tracking_rotation_deg > 0) {
    std::snprintf(buf, sizeof buf,
                  "; stated tracking accuracy %.3g mm / %.3g deg RMS (a rigid error of the data's "
                  "frame about the rows' centroid, added)",
                  uo.tracking_translation_mm, uo.tracking_rotation_deg);
    out.estimation += buf;
  } else {
    out.estimation += "; tracking accuracy not included (uncertainty.tracking_*: 0)";
  }
  if (confounded) {
    std::snprintf(buf, sizeof buf,
                  "; the pose was searched on this sweep and may carry sag: its motion (%.3g mm, "
                  "%.3g deg) added where the sag does not reach (uncertainty.pose_confounded)",
                  r.start.translation_mm, r.start.rotation_deg);
    out.estimation += buf;
  }
  out.node_sigma_mm = out.node_variance.cwiseSqrt();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.cpu_seconds = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  return out;
}

}  // namespace brainshift::constraints
