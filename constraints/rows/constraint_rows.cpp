#include "constraints/rows/constraint_rows.hpp"

#include "core/error.hpp"

#include <cmath>

namespace brainshift::constraints {

std::string to_string(ConstraintSet set) {
  switch (set) {
    case ConstraintSet::VESSELS:
      return "vessels";
    case ConstraintSet::FOOTPRINT:
      return "footprint";
    case ConstraintSet::DURA:
      return "dura";
    case ConstraintSet::FIXED:
      return "fixed";
    case ConstraintSet::LANDMARK:
      return "landmark";
  }
  BS_UNREACHABLE();
}

std::string to_string(ConstraintKind kind) {
  switch (kind) {
    case ConstraintKind::BILATERAL_POINT:
      return "bilateral_point";
    case ConstraintKind::SLIDING_LINE:
      return "sliding_line";
    case ConstraintKind::SLIDING_PLANE:
      return "sliding_plane";
    case ConstraintKind::UNILATERAL_PLANE:
      return "unilateral_plane";
  }
  BS_UNREACHABLE();
}

void Stencil::add(index_t n, double w) {
  for (int k = 0; k < size; ++k)
    if (node[k] == n) {
      weight[k] += w;
      return;
    }
  BS_VERIFY(size < capacity, "stencil holds at most " << capacity << " nodes");
  node[size] = n;
  weight[size] = w;
  ++size;
}

Vector3d Stencil::position(ConstRef<MatrixX3d> x) const {
  Vector3d p = Vector3d::Zero();
  for (int k = 0; k < size; ++k) p += weight[k] * x.row(node[k]).transpose();
  return p;
}

Stencil Stencil::interpolate(const Stencil& a, const Stencil& b, double t) {
  Stencil s;
  for (int k = 0; k < a.size; ++k)
    if (1 - t != 0.0) s.add(a.node[k], (1 - t) * a.weight[k]);
  for (int k = 0; k < b.size; ++k)
    if (t != 0.0) s.add(b.node[k], t * b.weight[k]);
  return s;
}

Stencil Stencil::combine(const Stencil& a, const Stencil& b, const Stencil& c, const Vector3d& w) {
  Stencil s;
  const Stencil* parts[3] = {&a, &b, &c};
  for (int p = 0; p < 3; ++p)
    if (w[p] != 0.0)
      for (int k = 0; k < parts[p]->size; ++k) s.add(parts[p]->node[k], w[p] * parts[p]->weight[k]);
  return s;
}

index_t ConstraintRows::add_row(const Stencil& s, ConstRef<MatrixX3d> x, const Vector3d& n,
                                const Vector3d& target, ConstraintLaw law, ConstraintKind kind,
                                ConstraintSet set, std::int64_t feature) {
  BS_VERIFY(s.size > 0, "constraint row has an empty stencil");
  BS_VERIFY(n.allFinite() && std::abs(n.norm() - 1.0) < 1e-9,
            "constraint direction must be a finite unit vector, got " << n.transpose());
  BS_VERIFY(target.allFinite(), "constraint target is not finite: " << target.transpose());
  for (int k = 0; k < s.size; ++k)
    BS_VERIFY(s.node[k] >= 0 && s.node[k] < x.rows(), "constraint stencil refers to node "
                                                          << s.node[k] << ", outside [0, "
                                                          << x.rows() << ")");
  ConstraintRow r;
  r.stencil = s;
  r.direction = n;
  r.offset = n.dot(target);
  r.violation = n.dot(s.position(x)) - r.offset;
  r.law = law;
  r.kind = kind;
  r.set = set;
  r.group = m_num_groups;
  r.feature = feature;
  m_rows.push_back(r);
  return m_num_groups;
}

index_t ConstraintRows::add_bilateral_point(const Stencil& s, ConstRef<MatrixX3d> x,
                                            const Vector3d& target, ConstraintSet set,
                                            std::int64_t feature) {
  for (int k = 0; k < 3; ++k)
    add_row(s, x, Vector3d::Unit(k), target, ConstraintLaw::BILATERAL,
            ConstraintKind::BILATERAL_POINT, set, feature);
  return m_num_groups++;
}

index_t ConstraintRows::add_sliding_line(const Stencil& s, ConstRef<MatrixX3d> x,
                                         const Vector3d& target, const Vector3d& tangent,
                                         ConstraintSet set, std::int64_t feature) {
  const double len = tangent.norm();
  BS_VERIFY(std::isfinite(len) && len > 0, "sliding-line tangent is zero or not finite");
  const Vector3d t = tangent / len;
  // n1: from the line towards the model point (the direction of projection), else any normal.
  Vector3d d = s.position(x) - target;
  d -= d.dot(t) * t;
  Vector3d n1 = d.norm() > 1e-12 * (1.0 + target.norm()) ? Vector3d(d.normalized())
                                                         : Vector3d(t.unitOrthogonal());
  const Vector3d n2 = t.cross(n1).normalized();
  add_row(s, x, n1, target, ConstraintLaw::BILATERAL, ConstraintKind::SLIDING_LINE, set, feature);
  add_row(s, x, n2, target, ConstraintLaw::BILATERAL, ConstraintKind::SLIDING_LINE, set, feature);
  return m_num_groups++;
}

index_t ConstraintRows::add_sliding_plane(const Stencil& s, ConstRef<MatrixX3d> x,
                                          const Vector3d& target, const Vector3d& normal,
                                          ConstraintSet set, std::int64_t feature) {
  add_row(s, x, normal.normalized(), target, ConstraintLaw::BILATERAL,
          ConstraintKind::SLIDING_PLANE, set, feature);
  return m_num_groups++;
}

index_t ConstraintRows::add_unilateral_plane(const Stencil& s, ConstRef<MatrixX3d> x,
                                             const Vector3d& target, const Vector3d& normal,
                                             ConstraintSet set, std::int64_t feature) {
  add_row(s, x, normal.normalized(), target, ConstraintLaw::UNILATERAL,
          ConstraintKind::UNILATERAL_PLANE, set, feature);
  return m_num_groups++;
}

void ConstraintRows::clear() {
  m_rows.clear();
  m_num_groups = 0;
}

SparseMatrix ConstraintRows::jacobian(index_t num_nodes) const {
  std::vector<Triplet> trip;
  trip.reserve(m_rows.size() * 12);
  for (index_t i = 0; i < size(); ++i) {
    const ConstraintRow& r = m_rows[i];
    for (int k = 0; k < r.stencil.size; ++k)
      for (int c = 0; c < 3; ++c)
        if (r.direction[c] != 0.0)
          trip.emplace_back(i, 3 * r.stencil.node[k] + c, r.stencil.weight[k] * r.direction[c]);
  }
  SparseMatrix H(size(), 3 * num_nodes);
  H.setFromTriplets(trip.begin(), trip.end());
  return H;
}

Eigen::VectorXd ConstraintRows::violations() const {
  Eigen::VectorXd d(size());
  for (index_t i = 0; i < size(); ++i) d[i] = m_rows[i].violation;
  return d;
}

Eigen::VectorXd ConstraintRows::values(ConstRef<MatrixX3d> x) const {
  Eigen::VectorXd g(size());
  for (index_t i = 0; i < size(); ++i)
    g[i] = m_rows[i].direction.dot(m_rows[i].stencil.position(x)) - m_rows[i].offset;
  return g;
}

std::array<index_t, num_constraint_sets> ConstraintRows::count_by_set() const {
  std::array<index_t, num_constraint_sets> c{};
  for (const auto& r : m_rows) ++c[static_cast<int>(r.set)];
  return c;
}

}  // namespace brainshift::constraints
