#include "imaging/meshing/label_mesher.hpp"

#include "core/logger.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/ImageIO.h>
#include <CGAL/Image_3.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Random.h>
#include <CGAL/make_mesh_3.h>
#include <CGAL/refine_mesh_3.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>
#include <unordered_map>

namespace brainshift::imaging {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Domain = CGAL::Labeled_mesh_domain_3<Kernel>;
using Triangulation = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using Complex = CGAL::Mesh_complex_3_in_triangulation_3<Triangulation>;
using Criteria = CGAL::Mesh_criteria_3<Triangulation>;

/// Background voxels added on every side, so that labels touching the border still give a closed
/// surface (CGAL's image function is 0 beyond the outermost voxel centres).
constexpr int kPad = 2;

/// Counts the voxels of each label value and rejects values outside 0–3 and all-background volumes.
void check_labels(const LabelVolume& labels) {
  std::array<std::int64_t, 256> count{};
  for (std::uint8_t v : labels.data) ++count[v];
  for (int v = 4; v < 256; ++v) {
    if (count[std::size_t(v)] == 0) continue;
    const auto& g = labels.geometry;
    std::int64_t first = 0;
    while (labels.data[std::size_t(first)] != v) ++first;
    const int i = int(first % g.size[0]);
    const int j = int((first / g.size[0]) % g.size[1]);
    const int k = int(first / (std::int64_t(g.size[0]) * g.size[1]));
    BS_THROW("label volume has label value "
             << v << " (" << count[std::size_t(v)] << " voxels, first at voxel (" << i << ", " << j
             << ", " << k << ")); allowed: 0 background, 1 brain, 2 tumour, 3 ventricles");
  }
  BS_VERIFY(
      count[0] < labels.geometry.voxel_count(),
      "label volume of " << labels.geometry.size.transpose()
                         << " voxels has no labelled voxel (all background): nothing to mesh");
}

/// The padded label image in CGAL's format.
CGAL::Image_3 make_image(const LabelVolume& labels) {
  const auto& g = labels.geometry;
  const std::size_t nx = std::size_t(g.size[0] + 2 * kPad);
  const std::size_t ny = std::size_t(g.size[1] + 2 * kPad);
  const std::size_t nz = std::size_t(g.size[2] + 2 * kPad);
  _image* im = ::_createImage(nx, ny, nz, 1, g.spacing[0], g.spacing[1], g.spacing[2], 1, WK_FIXED,
                              SGN_UNSIGNED);
  BS_VERIFY(im != nullptr,
            "could not allocate a " << nx << "×" << ny << "×" << nz << " label image for meshing");
  auto* out = static_cast<std::uint8_t*>(im->data);
  std::memset(out, 0, nx * ny * nz);
  for (int k = 0; k < g.size[2]; ++k) {
    for (int j = 0; j < g.size[1]; ++j) {
      for (int i = 0; i < g.size[0]; ++i) {
        const std::uint8_t v = labels.at(i, j, k);
        out[(std::size_t(k + kPad) * ny + std::size_t(j + kPad)) * nx + std::size_t(i + kPad)] = v;
      }
    }
  }
  im->tx = im->ty = im->tz = 0.0F;  // CGAL point q = (padded index) · spacing
  return CGAL::Image_3(im);         // takes ownership
}

/// Deterministic surface seeds: along grid lines through every `stride`-th voxel (in the two
/// other axes) of each axis, one point where the label changes between neighbouring voxels, put
/// on the surface by the domain's intersection construction. Every structure wider than the
/// stride gets seeds, which CGAL's default initialisation (rays from the centre) does not ensure
/// for inner structures such as an off-centre tumour.
void add_surface_seeds(Complex& c3t3, const Domain& domain, const CGAL::Image_3& image,
                       int stride) {
  const std::array<std::size_t, 3> n{image.xdim(), image.ydim(), image.zdim()};
  const std::array<double, 3> h{image.vx(), image.vy(), image.vz()};
  const auto* data = static_cast<const std::uint8_t*>(image.data());
  const auto label = [&](const std::array<std::size_t, 3>& p) {
    return data[(p[2] * n[1] + p[1]) * n[0] + p[0]];
  };
  const auto point = [&](const std::array<std::size_t, 3>& p) {
    return Kernel::Point_3(double(p[0]) * h[0], double(p[1]) * h[1], double(p[2]) * h[2]);
  };
  const auto intersect = domain.construct_intersection_object();
  auto& tr = c3t3.triangulation();
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    for (std::size_t a = 0; a < n[std::size_t(u)]; a += std::size_t(stride)) {
      for (std::size_t b = 0; b < n[std::size_t(w)]; b += std::size_t(stride)) {
        std::array<std::size_t, 3> p{};
        p[std::size_t(u)] = a;
        p[std::size_t(w)] = b;
        for (std::size_t t = 0; t + 1 < n[std::size_t(axis)]; ++t) {
          p[std::size_t(axis)] = t;
          std::array<std::size_t, 3> q = p;
          q[std::size_t(axis)] = t + 1;
          if (label(p) == label(q)) continue;
          const auto hit = intersect(Kernel::Segment_3(point(p), point(q)));
          if (std::get<2>(hit) == 0) continue;
          const auto v = tr.insert(Triangulation::Weighted_point(std::get<0>(hit)));
          if (v == Triangulation::Vertex_handle()) continue;
          c3t3.set_dimension(v, 2);
          c3t3.set_index(v, std::get<1>(hit));
        }
      }
    }
  }
}

/// Also inserts the domain's own initial surface points (rays from the centre, as make_mesh_3
/// does): together with the per-component seeds this gives every restricted surface a start.
void add_default_initial_points(Complex& c3t3, const Domain& domain) {
  std::vector<std::pair<Kernel::Point_3, Domain::Index>> points;
  domain.construct_initial_points_object()(std::back_inserter(points), 20);
  auto& tr = c3t3.triangulation();
  for (const auto& [p, index] : points) {
    const auto v = tr.insert(Triangulation::Weighted_point(p));
    if (v == Triangulation::Vertex_handle()) continue;  // hidden by another weighted point
    c3t3.set_dimension(v, 2);
    c3t3.set_index(v, index);
  }
}

/// CGAL warnings go to the brainshift logger instead of std::cerr.
void log_cgal_warning(const char* what, const char* expr, const char* file, int line,
                      const char* msg) {
  logger().warn("CGAL warning ({}): {} at {}:{}: {}", what ? what : "", expr ? expr : "",
                file ? file : "", line, msg ? msg : "");
}

/// Routes CGAL warnings to the logger while alive (the handler is process-global).
class CgalWarningsToLogger {
 public:
  CgalWarningsToLogger() : m_previous(CGAL::set_warning_handler(&log_cgal_warning)) {}
  ~CgalWarningsToLogger() { CGAL::set_warning_handler(m_previous); }
  CgalWarningsToLogger(const CgalWarningsToLogger&) = delete;
  CgalWarningsToLogger& operator=(const CgalWarningsToLogger&) = delete;

 private:
  CGAL::Failure_function m_previous;
};

double modulus_of(int label, const MeshingOptions& o) {
  switch (label) {
    case BRAIN:
      return o.brain_youngs_modulus;
    case TUMOUR:
      return o.tumour_youngs_modulus;
    case VENTRICLES:
      return o.ventricle_youngs_modulus;
    default:
      BS_THROW("internal error: sub-domain " << label << " is not a tissue label");
  }
}

/// Cells of the complex → world-frame TetMesh with one material per sub-domain.
MeshingResult to_tet_mesh(const Complex& c3t3, const ImageGeometry& g,
                          const MeshingOptions& options) {
  const Matrix3d index_to_world = g.direction * g.spacing.asDiagonal();
  const auto& tr = c3t3.triangulation();
  const bool cavity = options.ventricles == VentricleModel::CAVITY;
  // A cavity is meshed as a sub-domain (so its wall is resolved) and then left out.
  const auto kept = [&](const auto& c) {
    return !(cavity && c3t3.subdomain_index(c) == VENTRICLES);
  };
  // Nodes numbered in the triangulation's vertex order (deterministic: insertion order), so the
  // numbering does not depend on how exudation reconnected the cells.
  std::unordered_map<Triangulation::Vertex_handle, index_t> node_of;
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c) {
    if (!kept(c)) continue;
    for (int a = 0; a < 4; ++a) node_of.emplace(c->vertex(a), -1);
  }
  std::vector<Vector3d> nodes;
  for (auto v = tr.finite_vertices_begin(); v != tr.finite_vertices_end(); ++v) {
    const auto it = node_of.find(v);
    if (it == node_of.end()) continue;
    it->second = index_t(nodes.size());
    const auto& q = tr.point(v);
    const Vector3d ijk(q.x() / g.spacing[0] - kPad, q.y() / g.spacing[1] - kPad,
                       q.z() / g.spacing[2] - kPad);
    nodes.push_back(g.origin + index_to_world * ijk);
  }
  std::vector<std::array<index_t, 4>> tets;
  std::vector<std::uint8_t> labels;
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c) {
    if (!kept(c)) continue;
    std::array<index_t, 4> t{};
    for (int a = 0; a < 4; ++a) t[std::size_t(a)] = node_of.at(c->vertex(a));
    tets.push_back(t);
    labels.push_back(std::uint8_t(c3t3.subdomain_index(c)));
  }
  BS_VERIFY(!tets.empty(),
            "meshing gave no tetrahedron: the labelled structures are too small "
            "for cell_size "
                << options.cell_size << " mm / facet_size " << options.facet_size
                << " mm; use smaller sizes");

  MeshingResult result;
  MatrixX3d X(index_t(nodes.size()), 3);
  for (std::size_t n = 0; n < nodes.size(); ++n) X.row(index_t(n)) = nodes[n].transpose();
  MatrixX4i T(index_t(tets.size()), 4);
  Eigen::VectorXd E(index_t(tets.size()));
  for (std::size_t e = 0; e < tets.size(); ++e) {
    auto t = tets[e];
    const double v = core::signed_tet_volume(nodes[std::size_t(t[0])], nodes[std::size_t(t[1])],
                                             nodes[std::size_t(t[2])], nodes[std::size_t(t[3])]);
    if (v < 0.0) std::swap(t[2], t[3]);  // orientation-reversing direction (det = −1)
    T.row(index_t(e)) << t[0], t[1], t[2], t[3];
    E[index_t(e)] = modulus_of(labels[e], options);
  }
  Eigen::VectorXd nu = Eigen::VectorXd::Constant(T.rows(), options.poisson_ratio);
  result.mesh = core::TetMesh(std::move(X), std::move(T), std::move(E), std::move(nu));
  result.tet_label = std::move(labels);
  return result;
}

}  // namespace

MeshingOptions MeshingOptions::coarse() { return MeshingOptions{}; }

MeshingOptions MeshingOptions::refined(double refinement) {
  BS_VERIFY(std::isfinite(refinement) && refinement > 0.0,
            "mesh refinement must be a positive factor, got " << refinement);
  MeshingOptions o;
  o.cell_size /= refinement;
  o.facet_size /= refinement;
  o.facet_distance /= refinement;
  return o;
}

std::string MeshingOptions::validate() const {
  std::ostringstream s;
  auto positive = [](double x) { return std::isfinite(x) && x > 0.0; };
  if (!positive(cell_size))
    s << "cell_size must be > 0 mm, got " << cell_size;
  else if (!(cell_radius_edge_ratio >= 2.0))
    s << "cell_radius_edge_ratio must be ≥ 2, got " << cell_radius_edge_ratio;
  else if (!positive(facet_size))
    s << "facet_size must be > 0 mm, got " << facet_size;
  else if (!positive(facet_distance))
    s << "facet_distance must be > 0 mm, got " << facet_distance;
  else if (!(facet_angle_deg > 0.0 && facet_angle_deg <= 30.0))
    s << "facet_angle_deg must be in (0, 30], got " << facet_angle_deg;
  else if (!positive(brain_youngs_modulus))
    s << "brain_youngs_modulus must be > 0 kPa, got " << brain_youngs_modulus;
  else if (!positive(tumour_youngs_modulus))
    s << "tumour_youngs_modulus must be > 0 kPa, got " << tumour_youngs_modulus;
  else if (!positive(ventricle_youngs_modulus))
    s << "ventricle_youngs_modulus must be > 0 kPa, got " << ventricle_youngs_modulus;
  else if (!(poisson_ratio > -1.0 && poisson_ratio < 0.5))
    s << "poisson_ratio must be in (-1, 0.5), got " << poisson_ratio;
  return s.str();
}

MeshingResult mesh_labels(const LabelVolume& labels, const MeshingOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const std::string bad = options.validate();
  BS_VERIFY(bad.empty(), "meshing options: " << bad);
  const auto& g = labels.geometry;
  BS_VERIFY(g.size.minCoeff() > 0 && !labels.empty(),
            "label volume is empty (size " << g.size.transpose() << "): nothing to mesh");
  BS_VERIFY(labels.components == 1,
            "label volume must have one component, got " << labels.components);
  BS_VERIFY(
      labels.data.size() == std::size_t(g.voxel_count()),
      "label volume has " << labels.data.size() << " values for " << g.voxel_count() << " voxels");
  BS_VERIFY((g.direction.transpose() * g.direction - Matrix3d::Identity()).norm() < 1e-6,
            "label volume direction matrix is not orthonormal (|DᵀD − I| = "
                << (g.direction.transpose() * g.direction - Matrix3d::Identity()).norm() << ")");
  BS_VERIFY((g.spacing.array() > 0.0).all(),
            "label volume spacing must be > 0, got " << g.spacing.transpose());
  check_labels(labels);

  const CGAL::Image_3 image = make_image(labels);
  CGAL::Random rng(options.seed);
  CGAL::get_default_random() = CGAL::Random(options.seed);
  namespace params = CGAL::parameters;
  const Domain domain = Domain::create_labeled_image_mesh_domain(
      image, params::relative_error_bound = 1e-6, params::p_rng = &rng);
  const Criteria criteria(
      Criteria::Facet_criteria(options.facet_angle_deg, options.facet_size, options.facet_distance),
      Criteria::Cell_criteria(options.cell_radius_edge_ratio, options.cell_size));
  // Seed the surfaces of every structure (see add_surface_seeds), plus CGAL's default initial
  // points, then refine; no perturbation, Lloyd or ODT, optional exudation.
  Complex c3t3;
  const double seed_spacing = 2.0 * options.facet_size;  // mm between seeding lines
  add_surface_seeds(c3t3, domain, image,
                    std::max(2, int(std::lround(seed_spacing / g.spacing.maxCoeff()))));
  add_default_initial_points(c3t3, domain);
  const CgalWarningsToLogger warnings_to_logger;
  if (options.exude) {
    // time_limit = 0: exude until done. CGAL's default limit is the refinement's own wall time,
    // which made the mesh depend on the machine's load (the tet count varied run to run).
    CGAL::refine_mesh_3(c3t3, domain, criteria, params::no_perturb(),
                        params::exude(params::time_limit = 0), params::no_lloyd(),
                        params::no_odt());
  } else {
    CGAL::refine_mesh_3(c3t3, domain, criteria, params::no_perturb(), params::no_exude(),
                        params::no_lloyd(), params::no_odt());
  }

  MeshingResult result = to_tet_mesh(c3t3, g, options);
  core::validate(result.mesh, "label mesh");
  result.quality = core::quality_report(result.mesh);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  logger().info(
      "meshed labels {}×{}×{}: {} nodes, {} tets, min dihedral {:.1f}°, {} slivers, {:.2f} s",
      g.size[0], g.size[1], g.size[2], result.mesh.num_nodes(), result.mesh.num_tets(),
      result.quality.min_dihedral_deg, result.quality.sliver_count, result.seconds);
  return result;
}

}  // namespace brainshift::imaging
