#include "data_synth/geometry/label_anatomy.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"
#include "imaging/filters/gaussian.hpp"

#include <cmath>
#include <numbers>
#include <sstream>

namespace brainshift::data_synth {
namespace {

std::string fmt(const Vector3d& x) {
  std::ostringstream s;
  s << '(' << x.x() << ", " << x.y() << ", " << x.z() << ')';
  return s.str();
}

/// The label volume's brain as a 0/1 mask; checks every label is 0-3.
imaging::LabelVolume brain_mask(const imaging::LabelVolume& labels, const std::string& source) {
  BS_VERIFY(labels.components == 1 && labels.geometry.voxel_count() > 0,
            source << ": the label volume is empty or has " << labels.components << " components");
  imaging::LabelVolume mask(labels.geometry, 1, 0);
  std::int64_t brain = 0;
  for (std::size_t v = 0; v < labels.data.size(); ++v) {
    const std::uint8_t l = labels.data[v];
    BS_VERIFY(l <= imaging::VENTRICLES,
              source << ": label " << int(l) << " at voxel " << v
                     << " is not one of 0 background, 1 brain, 2 tumour, 3 ventricles");
    if (l != imaging::BACKGROUND) {
      mask.data[v] = 1;
      ++brain;
    }
  }
  BS_VERIFY(brain > 0,
            source << " has no brain: no voxel labelled 1 (brain), 2 (tumour) or 3 (ventricles)");
  return mask;
}

/// The default craniotomy direction: `up` tilted 25° toward +R (toward +A when up is along R).
Vector3d craniotomy_direction(const Vector3d& up) {
  const Vector3d u = up.normalized();
  Vector3d r = Vector3d::UnitX() - Vector3d::UnitX().dot(u) * u;
  if (r.norm() < 1e-6) r = Vector3d::UnitY() - Vector3d::UnitY().dot(u) * u;
  const double a = 25.0 * std::numbers::pi / 180.0;
  return std::cos(a) * u + std::sin(a) * r.normalized();
}

/// The hull point furthest along d: among the voxels at the zero level, then projected onto it.
Vector3d furthest_hull_point(const DistanceField& hull, const Vector3d& d) {
  const imaging::VolumeF& phi = hull.volume();
  const imaging::ImageGeometry& g = phi.geometry;
  double best = -1e300;
  Vector3d best_x = Vector3d::Zero();
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const float v = phi.at(i, j, k);
        if (v > 0.0F || v < -1.0F) continue;
        const Vector3d x = g.index_to_world(Vector3d(i, j, k));
        if (x.dot(d) > best) {
          best = x.dot(d);
          best_x = x;
        }
      }
  return hull.closest_point(best_x);
}

}  // namespace

std::string to_string(Placement p) {
  switch (p) {
    case Placement::GIVEN:
      return "given";
    case Placement::FROM_LABELS:
      return "from the labels";
    case Placement::DEFAULT:
      return "default";
  }
  return "?";
}

imaging::Label LabelAnatomy::voxel_label(const Vector3d& x) const {
  const Vector3d ijk = labels.geometry.world_to_index(x);
  const int i = int(std::lround(ijk.x())), j = int(std::lround(ijk.y())),
            k = int(std::lround(ijk.z()));
  if (!ijk.allFinite() || !labels.geometry.contains_index(i, j, k)) return imaging::BACKGROUND;
  return imaging::Label(labels.at(i, j, k));
}

imaging::Label LabelAnatomy::filled_label(const Vector3d& x) const {
  const imaging::Label l = voxel_label(x);
  if (l != imaging::BACKGROUND) return l;
  return hull->value(x) < 0.0 ? imaging::BRAIN : imaging::BACKGROUND;
}

BrainShape LabelAnatomy::shape() const {
  BrainShape s;
  // The shape may outlive this object: it keeps copies of what it reads (the labels by pointer).
  const auto self = std::make_shared<const LabelAnatomy>(*this);
  s.label_at = [self](const Vector3d& x) { return self->filled_label(x); };
  s.closest_surface_point = [h = hull](const Vector3d& x) { return h->closest_point(x); };
  s.surface_normal = [h = hull](const Vector3d& x) { return h->normal(x); };
  s.craniotomy_centre = craniotomy_centre;
  s.craniotomy_radius = craniotomy_radius;
  s.tumour_centre = tumour_centre;
  s.tumour_radius = tumour_radius;
  return s;
}

LabelAnatomy make_label_anatomy(const imaging::LabelVolume& labels, const LabelAnatomyOptions& o,
                                const std::string& source) {
  BS_VERIFY(o.up.allFinite() && o.up.norm() > 0.0, "the up direction must be finite and non-zero");
  BS_VERIFY(o.skull_gap >= 0.0 && o.closing_radius >= 0.0 && o.hull_smoothing >= 0.0 &&
                o.craniotomy_radius > 0.0 && o.default_tumour_radius > 0.0 && o.base_height > 0.0,
            "label anatomy options: skull_gap, closing_radius, hull_smoothing >= 0; radii and "
            "base_height > 0");
  const imaging::LabelVolume mask = brain_mask(labels, source);
  LabelAnatomy a;
  a.labels = labels;
  a.craniotomy_radius = o.craniotomy_radius;
  a.skull_gap = o.skull_gap;
  a.base_height = o.base_height;

  // The hull: closed, signed distance, smoothed. The skull: the brain closed by a larger ball
  // (it bridges the concave notches, e.g. between the occipital lobes and the cerebellum, where
  // a closest-point projection would jump between the two sides), grown by the gap.
  const double pad = o.skull_gap + 3.0 * o.hull_smoothing + 5.0;
  auto smooth_distance = [&](double closing) {
    const imaging::LabelVolume closed = closing > 0.0 ? close_mask(mask, closing, pad) : mask;
    imaging::VolumeF phi = signed_distance(closed, closing > 0.0 ? 0.0 : pad).volume();
    if (o.hull_smoothing > 0.0) phi = imaging::filters::gaussian_filter(phi, o.hull_smoothing);
    return phi;
  };
  imaging::VolumeF skull = smooth_distance(std::max(o.closing_radius, o.skull_closing_radius));
  for (float& v : skull.data) v -= float(o.skull_gap);
  a.hull = std::make_shared<const DistanceField>(smooth_distance(o.closing_radius));
  a.skull = std::make_shared<const DistanceField>(std::move(skull));

  // Craniotomy.
  if (o.craniotomy) {
    const Vector3d c = *o.craniotomy;
    BS_VERIFY(c.allFinite(), "craniotomy " << fmt(c) << " is not finite");
    const double d = a.hull->value(c);
    BS_VERIFY(std::abs(d) <= o.max_craniotomy_distance,
              "craniotomy " << fmt(c) << " mm is outside the brain of " << source << ": "
                            << std::abs(d) << " mm from its surface (at most "
                            << o.max_craniotomy_distance << " mm)");
    a.craniotomy_centre = a.hull->closest_point(c);
    a.craniotomy_placement = Placement::GIVEN;
  } else {
    a.craniotomy_centre = furthest_hull_point(*a.hull, craniotomy_direction(o.up));
    a.craniotomy_placement = Placement::DEFAULT;
  }
  a.craniotomy_normal = a.hull->normal(a.craniotomy_centre);

  // Tumour: given, the labels' own, or the default beneath the craniotomy.
  Vector3d sum = Vector3d::Zero();
  std::int64_t tumour_voxels = 0;
  const imaging::ImageGeometry& g = labels.geometry;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        if (labels.at(i, j, k) == imaging::TUMOUR) {
          sum += g.index_to_world(Vector3d(i, j, k));
          ++tumour_voxels;
        }
  const double voxel_ml = g.spacing.prod() / 1000.0;
  if (o.tumour_centre) {
    a.tumour_centre = *o.tumour_centre;
    a.tumour_radius = o.tumour_radius.value_or(o.default_tumour_radius);
    a.tumour_placement = Placement::GIVEN;
  } else if (tumour_voxels > 0) {
    a.tumour_centre = sum / double(tumour_voxels);
    a.tumour_radius =
        std::cbrt(3.0 * double(tumour_voxels) * voxel_ml * 1000.0 / (4.0 * std::numbers::pi));
    a.tumour_placement = Placement::FROM_LABELS;
  } else {
    a.tumour_centre = a.craniotomy_centre - o.default_tumour_depth * a.craniotomy_normal;
    a.tumour_radius = o.tumour_radius.value_or(o.default_tumour_radius);
    a.tumour_placement = Placement::DEFAULT;
  }
  BS_VERIFY(a.tumour_centre.allFinite(),
            "tumour centre " << fmt(a.tumour_centre) << " is not finite");
  BS_VERIFY(std::isfinite(a.tumour_radius) && a.tumour_radius > 0.0,
            "tumour radius " << a.tumour_radius << " mm must be positive");
  const imaging::Label at_centre = a.voxel_label(a.tumour_centre);
  BS_VERIFY(
      at_centre == imaging::BRAIN || at_centre == imaging::TUMOUR,
      (a.tumour_placement == Placement::DEFAULT ? "the default tumour centre " : "tumour centre ")
          << fmt(a.tumour_centre) << " mm is outside the brain of " << source << " (label "
          << int(at_centre) << " there)"
          << (a.tumour_placement == Placement::DEFAULT ? "; give --tumour X,Y,Z,RADIUS" : ""));

  // Write the tumour into the labels (a given or default sphere), and measure the brain.
  if (a.tumour_placement != Placement::FROM_LABELS) {
    const Vector3d lo =
        g.world_to_index(a.tumour_centre) - (a.tumour_radius / g.spacing.array()).matrix();
    const Vector3d hi =
        g.world_to_index(a.tumour_centre) + (a.tumour_radius / g.spacing.array()).matrix();
    for (int k = std::max(0, int(std::floor(std::min(lo.z(), hi.z()))));
         k <= std::min(g.size[2] - 1, int(std::ceil(std::max(lo.z(), hi.z())))); ++k)
      for (int j = std::max(0, int(std::floor(std::min(lo.y(), hi.y()))));
           j <= std::min(g.size[1] - 1, int(std::ceil(std::max(lo.y(), hi.y())))); ++j)
        for (int i = std::max(0, int(std::floor(std::min(lo.x(), hi.x()))));
             i <= std::min(g.size[0] - 1, int(std::ceil(std::max(lo.x(), hi.x())))); ++i) {
          std::uint8_t& l = a.labels.at(i, j, k);
          if (l != imaging::BACKGROUND &&
              (g.index_to_world(Vector3d(i, j, k)) - a.tumour_centre).norm() <= a.tumour_radius)
            l = imaging::TUMOUR;
        }
  }
  std::int64_t brain = 0;
  for (const std::uint8_t l : a.labels.data) brain += l != imaging::BACKGROUND;
  a.brain_volume_ml = double(brain) * voxel_ml;
  logger().info(
      "label anatomy {}: {:.0f} mL of brain, craniotomy ({:.1f}, {:.1f}, {:.1f}) {}, tumour "
      "({:.1f}, {:.1f}, "
      "{:.1f}) r {:.1f} mm {}",
      source, a.brain_volume_ml, a.craniotomy_centre.x(), a.craniotomy_centre.y(),
      a.craniotomy_centre.z(), to_string(a.craniotomy_placement), a.tumour_centre.x(),
      a.tumour_centre.y(), a.tumour_centre.z(), a.tumour_radius, to_string(a.tumour_placement));
  return a;
}

PhantomMesh make_label_mesh(const LabelAnatomy& a, const PhantomMeshOptions& o) {
  const std::string bad = o.validate();
  BS_VERIFY(bad.empty(), "invalid phantom mesh options: " << bad);
  const double h = o.cell_size;
  // Bounding box of the hull's interior.
  const imaging::VolumeF& phi = a.hull->volume();
  const imaging::ImageGeometry& g = phi.geometry;
  Vector3d lo = Vector3d::Constant(1e300), hi = Vector3d::Constant(-1e300);
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        if (phi.at(i, j, k) < 0.0F) {
          const Vector3d x = g.index_to_world(Vector3d(i, j, k));
          lo = lo.cwiseMin(x);
          hi = hi.cwiseMax(x);
        }
  BS_VERIFY(lo.x() <= hi.x(), "the brain's hull is empty");
  const Vector3d origin = lo - Vector3d::Constant(h);
  const Eigen::Vector3i cells = ((hi - lo) / h).array().ceil().cast<int>() + 2;
  const CubeTets cubes =
      make_cube_tets(origin, h, cells, [&](const Vector3d& x) { return a.hull->value(x) < 0.0; });
  BS_VERIFY(!cubes.ijk.empty(),
            "label mesh is empty: cell_size " << h << " mm is too large for the brain");

  const MatrixX3d& rest = cubes.nodes;
  MatrixX3d nodes = rest;
  std::vector<char> snapped(cubes.ijk.size(), 0);
  std::vector<index_t> boundary;
  for (std::size_t n = 0; n < cubes.ijk.size(); ++n)
    if (cubes.boundary[n]) boundary.push_back(index_t(n));
  if (o.snap_to_surface) {
    for (const index_t n : boundary) {
      nodes.row(n) = a.hull->closest_point(rest.row(n).transpose()).transpose();
      snapped[std::size_t(n)] = 1;
    }
    undo_flattening_snaps(rest, cubes.tets, o.min_snapped_volume_fraction, nodes, snapped);
  }
  PhantomMesh out;
  double lowest = 1e300;
  for (const index_t n : boundary) lowest = std::min(lowest, nodes(n, 2));
  for (const index_t n : boundary)
    (nodes(n, 2) <= lowest + a.base_height ? out.base_nodes : out.surface_nodes).push_back(n);
  for (const char s : snapped) out.snapped_nodes += s;
  assign_materials(
      std::move(nodes), cubes.tets, [&](const Vector3d& x) { return a.voxel_label(x); }, o, out);
  logger().info(
      "label truth mesh: h {} mm, {} nodes, {} tets, {} fixed base nodes, {} snapped of {} "
      "boundary nodes",
      h, out.mesh.num_nodes(), out.mesh.num_tets(), out.base_nodes.size(), out.snapped_nodes,
      boundary.size());
  return out;
}

}  // namespace brainshift::data_synth
