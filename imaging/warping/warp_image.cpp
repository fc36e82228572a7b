#include "imaging/warping/warp_image.hpp"

#include "core/logger.hpp"
#include "core/mesh/boundary.hpp"
#include "core/parallel.hpp"
#include "core/timing.hpp"
#include "imaging/filters/trilinear.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

namespace brainshift::imaging {

namespace {

/// Affine map p ↦ A p + b (3D).
struct Affine {
  Matrix3d A = Matrix3d::Identity();
  Vector3d b = Vector3d::Zero();
  [[nodiscard]] Vector3d operator()(const Vector3d& p) const { return A * p + b; }
};

/// A tetrahedron prepared for rasterisation in the output grid: barycentric coordinates
/// λ(p) = L p + c of an output index p, and the mapped attribute a(p) = G p + h (an input index
/// for warping, a displacement for the field), both affine in p.
struct PreparedTet {
  Eigen::Matrix<double, 4, 3> L;
  Vector4d c;
  Matrix3d G;
  Vector3d h;
  Vector4d tol = Vector4d::Zero();         ///< voxel centres with λ_v ≥ −tol_v count as inside
  Vector4d inv_height = Vector4d::Zero();  ///< |∇λ_v| in world mm⁻¹ (1 / height from v)
  Eigen::Vector3i lo, hi;                  ///< inclusive voxel bounding box, clipped to the grid
  bool empty = true;
};

/// Barycentric tolerance: voxel centres on a face (λ = 0 up to rounding) count as inside.
constexpr double kInsideTol = 1e-9;

/// `q`: vertices in output index space; `a`: attributes; `w`: vertices in world mm (for the
/// extension margin); `margin_mm` > 0 dilates the tetrahedron by that distance beyond each face
/// plane and `margin_index` (≥ margin in index units along every axis) grows its bounding box.
PreparedTet prepare(const std::array<Vector3d, 4>& q, const std::array<Vector3d, 4>& a,
                    const std::array<Vector3d, 4>& w, const Eigen::Vector3i& size, double margin_mm,
                    double margin_index) {
  PreparedTet t;
  Matrix3d E;
  E << q[1] - q[0], q[2] - q[0], q[3] - q[0];
  const double scale = std::max({E.col(0).norm(), E.col(1).norm(), E.col(2).norm()});
  if (!(std::abs(E.determinant()) > 1e-12 * scale * scale * scale)) return t;  // flat: skip
  const Matrix3d M = E.inverse();
  t.L.bottomRows<3>() = M;
  t.L.row(0) = -M.colwise().sum();
  t.c.tail<3>() = -M * q[0];
  t.c[0] = 1.0 - t.c.tail<3>().sum();
  Matrix3d D;
  D << a[1] - a[0], a[2] - a[0], a[3] - a[0];
  t.G = D * M;
  t.h = a[0] - t.G * q[0];
  t.tol.setConstant(kInsideTol);
  Matrix3d Ew;
  Ew << w[1] - w[0], w[2] - w[0], w[3] - w[0];
  const double det_w = Ew.determinant();
  if (det_w != 0.0 && std::isfinite(det_w)) {
    const Matrix3d Mw = Ew.inverse();  // rows: world gradients of λ_1..3
    t.inv_height << Mw.colwise().sum().norm(), Mw.row(0).norm(), Mw.row(1).norm(), Mw.row(2).norm();
    t.tol += margin_mm * t.inv_height;
  }
  Vector3d mn = q[0], mx = q[0];
  for (int v = 1; v < 4; ++v) {
    mn = mn.cwiseMin(q[std::size_t(v)]);
    mx = mx.cwiseMax(q[std::size_t(v)]);
  }
  mn.array() -= margin_index;
  mx.array() += margin_index;
  for (int d = 0; d < 3; ++d) {
    // Clamp in double before the int casts: a far-away tetrahedron must not overflow them.
    t.lo[d] = int(std::clamp(std::ceil(mn[d] - 1e-6), 0.0, double(size[d])));
    t.hi[d] = int(std::clamp(std::floor(mx[d] + 1e-6), -1.0, double(size[d] - 1)));
  }
  t.empty = (t.lo.array() > t.hi.array()).any();
  return t;
}

/// Calls f(linear voxel index, attribute, λ) for every voxel centre of planes [k0, k1) inside t
/// (λ_v ≥ −t.tol_v for every v).
template <typename F>
void rasterise(const PreparedTet& t, const Eigen::Vector3i& size, int k0, int k1, F&& f) {
  const int kb = std::max(k0, t.lo[2]);
  const int ke = std::min(k1 - 1, t.hi[2]);
  const Vector4d s = t.L.col(0);  // dλ/di
  for (int k = kb; k <= ke; ++k) {
    for (int j = t.lo[1]; j <= t.hi[1]; ++j) {
      const Vector4d b = t.L.col(1) * j + t.L.col(2) * k + t.c;  // λ at i = 0
      double ilo = t.lo[0], ihi = t.hi[0];
      for (int v = 0; v < 4; ++v) {  // λ_v(i) = b_v + s_v i ≥ −tol_v
        if (s[v] > 0.0)
          ilo = std::max(ilo, (-t.tol[v] - b[v]) / s[v]);
        else if (s[v] < 0.0)
          ihi = std::min(ihi, (-t.tol[v] - b[v]) / s[v]);
        else if (b[v] < -t.tol[v])
          ihi = -1.0;
      }
      if (!(ilo <= ihi)) continue;  // empty span (the bounds may be huge: test before int casts)
      const int ib = int(std::ceil(ilo));
      const int ie = int(std::floor(ihi));
      if (ib > ie) continue;
      const Vector3d row = t.G.col(1) * j + t.G.col(2) * k + t.h;
      const std::int64_t base = (std::int64_t(k) * size[1] + j) * size[0];
      for (int i = ib; i <= ie; ++i)
        f(base + i, Vector3d(row + t.G.col(0) * i), Vector4d(b + s * i));
    }
  }
}

/// Runs body(k0, k1) on `threads` slabs of planes.
template <typename F>
void for_slabs(int nk, int threads, F&& body) {
  threads = std::max(1, std::min(threads, nk));
  if (threads == 1) {
    body(0, nk);
    return;
  }
  core::parallel_chunks(static_cast<std::size_t>(threads), threads, [&](std::size_t w) {
    const auto t = static_cast<std::int64_t>(threads);
    body(int(nk * static_cast<std::int64_t>(w) / t),
         int(nk * static_cast<std::int64_t>(w + 1) / t));
  });
}

void check_mesh_input(const core::TetMesh& mesh, ConstRef<MatrixX3d> displacement,
                      const Eigen::Matrix4d& rigid, int threads) {
  BS_VERIFY(displacement.rows() == mesh.num_nodes(),
            "displacement has " << displacement.rows() << " rows, the mesh has " << mesh.num_nodes()
                                << " nodes");
  BS_VERIFY(displacement.allFinite(), "displacement has a NaN or infinite value");
  const Matrix3d R = rigid.topLeftCorner<3, 3>();
  BS_VERIFY(rigid.allFinite() && (R.transpose() * R - Matrix3d::Identity()).norm() < 1e-6 &&
                R.determinant() > 0.0 && rigid.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)),
            "the rigid transform outside the mesh is not a rotation + translation: |RᵀR − I| = "
                << (R.transpose() * R - Matrix3d::Identity()).norm()
                << ", det R = " << R.determinant() << ", last row " << rigid.row(3));
  BS_VERIFY(threads >= 1, "threads must be ≥ 1, got " << threads);
}

/// world → index of g, as an affine map.
Affine world_to_index(const ImageGeometry& g) {
  Affine m;
  m.A = g.spacing.cwiseInverse().asDiagonal() * g.direction.transpose();
  m.b = -m.A * g.origin;
  return m;
}

/// index → world of g, as an affine map.
Affine index_to_world(const ImageGeometry& g) {
  Affine m;
  m.A = g.direction * g.spacing.asDiagonal();
  m.b = g.origin;
  return m;
}

Affine compose(const Affine& f, const Affine& g) {  // f ∘ g
  return {f.A * g.A, f.A * g.b + f.b};
}

/// Prepares every tetrahedron: vertices `q` (output index space), attributes `a`, world
/// vertices `w` and the dilation margin (see prepare()).
std::vector<PreparedTet> prepare_all(const core::TetMesh& mesh, const MatrixX3d& q_nodes,
                                     const MatrixX3d& a_nodes, const MatrixX3d& w_nodes,
                                     const Eigen::Vector3i& size, double margin_mm = 0.0,
                                     double margin_index = 0.0) {
  std::vector<PreparedTet> tets(std::size_t(mesh.num_tets()));
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    std::array<Vector3d, 4> q, a, w;
    for (int v = 0; v < 4; ++v) {
      q[std::size_t(v)] = q_nodes.row(mesh.tets()(t, v)).transpose();
      a[std::size_t(v)] = a_nodes.row(mesh.tets()(t, v)).transpose();
      w[std::size_t(v)] = w_nodes.row(mesh.tets()(t, v)).transpose();
    }
    tets[std::size_t(t)] = prepare(q, a, w, size, margin_mm, margin_index);
  }
  return tets;
}

MatrixX3d map_rows(const Affine& m, const MatrixX3d& P) {
  MatrixX3d out(P.rows(), 3);
  for (index_t r = 0; r < P.rows(); ++r) out.row(r) = m(P.row(r).transpose()).transpose();
  return out;
}

using core::seconds_since;

void check_extension(double extension_mm) {
  BS_VERIFY(std::isfinite(extension_mm) && extension_mm >= 0.0,
            "the extension beyond the mesh must be ≥ 0 mm, got " << extension_mm);
}

/// Shared body of displacement_field() and inverse_displacement_field(). The field is
/// `outside(ijk)` everywhere, then, on every voxel centre inside a tetrahedron (vertices
/// `nodes_world`, world mm), the affine interpolation of `values`. With `margin_mm` > 0, voxel
/// centres inside no tetrahedron but within margin_mm of the face planes of one take the affine
/// extension of the tetrahedron they are least outside of (largest face-plane distance, the
/// smallest over tetrahedra).
/// With `exact` (and margin_mm > 0), the field without the extension (margin 0) is also
/// stored there, from the same rasterisation: each slab is copied after the inside pass.
VolumeF rasterised_field(const core::TetMesh& mesh, const MatrixX3d& nodes_world,
                         const MatrixX3d& values, const Affine& outside, const ImageGeometry& g,
                         double margin_mm, int threads, VolumeF* exact = nullptr) {
  VolumeF out(g, 3, 0.0F);
  if (exact) *exact = VolumeF(g, 3, 0.0F);
  const MatrixX3d q = map_rows(world_to_index(g), nodes_world);
  const auto tets = prepare_all(mesh, q, values, nodes_world, g.size);
  std::vector<PreparedTet> wide;
  std::vector<float> outside_by(0);  // per voxel: how far outside its writer it is (0: inside)
  if (margin_mm > 0.0) {
    // Only tetrahedra touching the boundary can be nearest to a voxel outside the mesh (an inner
    // one's extension reaches only voxels inside other tetrahedra): dilate just those.
    wide = prepare_all(mesh, q, values, nodes_world, g.size, margin_mm,
                       margin_mm / g.spacing.minCoeff());
    std::vector<bool> on_boundary(std::size_t(mesh.num_nodes()), false);
    const core::TriangleMatrix faces = core::boundary_faces(mesh);
    for (Eigen::Index f = 0; f < faces.size(); ++f)
      on_boundary[std::size_t(faces.data()[f])] = true;
    for (index_t t = 0; t < mesh.num_tets(); ++t) {
      bool touches = false;
      for (int a = 0; a < 4; ++a) touches = touches || on_boundary[std::size_t(mesh.tets()(t, a))];
      if (!touches) wide[std::size_t(t)].empty = true;
    }
    outside_by.assign(std::size_t(g.voxel_count()), std::numeric_limits<float>::infinity());
  }
  for_slabs(g.size[2], threads, [&](int k0, int k1) {
    for (int k = k0; k < k1; ++k) {
      for (int j = 0; j < g.size[1]; ++j) {
        float* row = &out.at(0, j, k, 0);
        const Vector3d d0 = outside(Vector3d(0, j, k));
        for (int i = 0; i < g.size[0]; ++i) {
          const Vector3d d = d0 + outside.A.col(0) * i;
          for (int c = 0; c < 3; ++c) row[3 * i + c] = float(d[c]);
        }
      }
    }
    float* data = out.data.data();
    const bool extend = !wide.empty();
    for (const PreparedTet& tet : tets) {
      if (tet.empty || tet.hi[2] < k0 || tet.lo[2] >= k1) continue;
      rasterise(tet, g.size, k0, k1, [&](std::int64_t v, const Vector3d& d, const Vector4d&) {
        for (int c = 0; c < 3; ++c) data[3 * v + c] = float(d[c]);
        if (extend) outside_by[std::size_t(v)] = 0.0F;
      });
    }
    if (exact) {
      const std::size_t plane = std::size_t(g.size[0]) * std::size_t(g.size[1]) * 3;
      std::copy(data + plane * std::size_t(k0), data + plane * std::size_t(k1),
                exact->data.data() + plane * std::size_t(k0));
    }
    for (const PreparedTet& tet : wide) {
      if (tet.empty || tet.hi[2] < k0 || tet.lo[2] >= k1) continue;
      rasterise(tet, g.size, k0, k1,
                [&](std::int64_t v, const Vector3d& d, const Vector4d& lambda) {
                  float& best = outside_by[std::size_t(v)];
                  if (best == 0.0F) return;  // inside a tetrahedron: exact value already there
                  double dist = 0.0;         // distance beyond the farthest-violated face plane, mm
                  for (int a = 0; a < 4; ++a)
                    if (tet.inv_height[a] > 0.0)
                      dist = std::max(dist, -lambda[a] / tet.inv_height[a]);
                  const float key = std::max(float(dist), std::numeric_limits<float>::min());
                  if (!(key < best)) return;
                  best = key;
                  for (int c = 0; c < 3; ++c) data[3 * v + c] = float(d[c]);
                });
    }
  });
  return out;
}

}  // namespace

float sample_trilinear(const VolumeF& image, const Vector3d& ijk, float outside_value,
                       int component) {
  if (!filters::on_sampling_grid(image.geometry, ijk)) return outside_value;
  return filters::sample_trilinear(image, ijk, filters::MissingData::NAN_RESULT, component);
}

VolumeF warp_image(const VolumeF& image, const core::TetMesh& mesh,
                   ConstRef<MatrixX3d> displacement, const WarpOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  BS_VERIFY(
      !image.empty() && image.geometry.size.minCoeff() > 0,
      "warp_image: the input image is empty (size " << image.geometry.size.transpose() << ")");
  BS_VERIFY(image.components == 1, "warp_image: the input image must be scalar, it has "
                                       << image.components << " components");
  check_mesh_input(mesh, displacement, options.rigid, options.threads);
  const ImageGeometry out_g = options.output_geometry.value_or(image.geometry);
  BS_VERIFY(out_g.size.minCoeff() > 0, "warp_image: the output grid is empty");

  VolumeF out(out_g, 1, options.outside_value);
  // Outside the mesh: input index = in.world_to_index(T⁻¹ · out.index_to_world(ijk)).
  const Matrix3d R = options.rigid.topLeftCorner<3, 3>();
  const Vector3d t = options.rigid.topRightCorner<3, 1>();
  const Affine rigid_inverse{R.transpose(), -R.transpose() * t};
  const Affine outside =
      compose(world_to_index(image.geometry), compose(rigid_inverse, index_to_world(out_g)));
  // Inside: deformed nodes in output index space, rest nodes in input index space.
  const MatrixX3d deformed = mesh.nodes() + displacement;
  const auto tets =
      prepare_all(mesh, map_rows(world_to_index(out_g), deformed),
                  map_rows(world_to_index(image.geometry), mesh.nodes()), deformed, out_g.size);
  const float fill = options.outside_value;
  for_slabs(out_g.size[2], options.threads, [&](int k0, int k1) {
    for (int k = k0; k < k1; ++k) {
      for (int j = 0; j < out_g.size[1]; ++j) {
        float* row = &out.at(0, j, k);
        const Vector3d p0 = outside(Vector3d(0, j, k));
        for (int i = 0; i < out_g.size[0]; ++i) {
          row[i] = sample_trilinear(image, p0 + outside.A.col(0) * i, fill);
        }
      }
    }
    float* data = out.data.data();
    for (const PreparedTet& tet : tets) {
      if (tet.empty || tet.hi[2] < k0 || tet.lo[2] >= k1) continue;
      rasterise(tet, out_g.size, k0, k1, [&](std::int64_t v, const Vector3d& ijk, const Vector4d&) {
        data[v] = sample_trilinear(image, ijk, fill);
      });
    }
  });
  logger().debug("warp_image: {}×{}×{} voxels, {} tets, {:.3f} s", out_g.size[0], out_g.size[1],
                 out_g.size[2], mesh.num_tets(), seconds_since(start));
  return out;
}

VolumeF displacement_field(const core::TetMesh& mesh, ConstRef<MatrixX3d> displacement,
                           const ImageGeometry& geometry, const DisplacementFieldOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  BS_VERIFY(geometry.size.minCoeff() > 0,
            "displacement_field: the grid is empty (size " << geometry.size.transpose() << ")");
  check_mesh_input(mesh, displacement, options.rigid, options.threads);
  check_extension(options.extension_mm);
  // Outside the mesh: u = T X − X = (R − I) X + t with X = index_to_world(ijk).
  const Affine rigid_displacement{
      Matrix3d(options.rigid.topLeftCorner<3, 3>() - Matrix3d::Identity()),
      options.rigid.topRightCorner<3, 1>()};
  const MatrixX3d u = displacement;
  VolumeF out =
      rasterised_field(mesh, mesh.nodes(), u, compose(rigid_displacement, index_to_world(geometry)),
                       geometry, options.extension_mm, options.threads);
  logger().debug("displacement_field: {}×{}×{} voxels, {} tets, {:.3f} s", geometry.size[0],
                 geometry.size[1], geometry.size[2], mesh.num_tets(), seconds_since(start));
  return out;
}

ForwardDisplacementFields displacement_fields(const core::TetMesh& mesh,
                                              ConstRef<MatrixX3d> displacement,
                                              const ImageGeometry& geometry,
                                              const DisplacementFieldOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  BS_VERIFY(geometry.size.minCoeff() > 0,
            "displacement_fields: the grid is empty (size " << geometry.size.transpose() << ")");
  check_mesh_input(mesh, displacement, options.rigid, options.threads);
  check_extension(options.extension_mm);
  const Affine rigid_displacement{
      Matrix3d(options.rigid.topLeftCorner<3, 3>() - Matrix3d::Identity()),
      options.rigid.topRightCorner<3, 1>()};
  const MatrixX3d u = displacement;
  ForwardDisplacementFields f;
  if (options.extension_mm > 0.0) {
    f.extended = rasterised_field(mesh, mesh.nodes(), u,
                                  compose(rigid_displacement, index_to_world(geometry)), geometry,
                                  options.extension_mm, options.threads, &f.exact);
  } else {
    f.exact = rasterised_field(mesh, mesh.nodes(), u,
                               compose(rigid_displacement, index_to_world(geometry)), geometry, 0.0,
                               options.threads);
    f.extended = f.exact;
  }
  logger().debug("displacement_fields: {}×{}×{} voxels, {} tets, {:.3f} s", geometry.size[0],
                 geometry.size[1], geometry.size[2], mesh.num_tets(), seconds_since(start));
  return f;
}

VolumeF inverse_displacement_field(const core::TetMesh& mesh, ConstRef<MatrixX3d> displacement,
                                   const ImageGeometry& geometry,
                                   const DisplacementFieldOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  BS_VERIFY(geometry.size.minCoeff() > 0, "inverse_displacement_field: the grid is empty (size "
                                              << geometry.size.transpose() << ")");
  check_mesh_input(mesh, displacement, options.rigid, options.threads);
  check_extension(options.extension_mm);
  // Outside the deformed mesh: v = T⁻¹ y − y = (Rᵀ − I) y − Rᵀ t.
  const Matrix3d R = options.rigid.topLeftCorner<3, 3>();
  const Vector3d t = options.rigid.topRightCorner<3, 1>();
  const Affine rigid_inverse_displacement{Matrix3d(R.transpose() - Matrix3d::Identity()),
                                          -R.transpose() * t};
  // Inside: the deformed tetrahedra carry v = X − x, affine on each, −u_a at its vertices.
  const MatrixX3d deformed = mesh.nodes() + displacement;
  const MatrixX3d minus_u = -displacement;
  VolumeF out = rasterised_field(mesh, deformed, minus_u,
                                 compose(rigid_inverse_displacement, index_to_world(geometry)),
                                 geometry, options.extension_mm, options.threads);
  logger().debug("inverse_displacement_field: {}×{}×{} voxels, {} tets, {:.3f} s", geometry.size[0],
                 geometry.size[1], geometry.size[2], mesh.num_tets(), seconds_since(start));
  return out;
}

double trilinear_support_mm(const ImageGeometry& geometry) { return geometry.spacing.norm(); }

ImageGeometry covering_grid(const ImageGeometry& like, ConstRef<MatrixX3d> points,
                            double margin_mm) {
  BS_VERIFY(points.rows() > 0 && points.allFinite(),
            "covering_grid: no points, or a non-finite one");
  BS_VERIFY(margin_mm >= 0.0 && std::isfinite(margin_mm),
            "covering_grid: bad margin " << margin_mm);
  const Affine to_index = world_to_index(like);
  Vector3d lo = Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (index_t r = 0; r < points.rows(); ++r) {
    const Vector3d p = to_index(points.row(r).transpose());
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vector3d m = margin_mm * like.spacing.cwiseInverse();
  lo = (lo - m).array().floor();
  hi = (hi + m).array().ceil();
  const Vector3d n = hi - lo + Vector3d::Ones();
  BS_VERIFY((n.array() < double(1 << 20)).all() && n.prod() < 2e9,
            "covering_grid: the points span " << n.transpose() << " voxels, too large a grid");
  ImageGeometry g = like;
  g.size = n.cast<int>();
  g.origin = like.index_to_world(lo);
  return g;
}

}  // namespace brainshift::imaging
