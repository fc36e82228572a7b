/// @file
/// @brief Diagnostic (issue 14 item 3): the systematic error of the intra-operative vessel points
/// against the truth. For one phantom case and seed it builds the case and the model as `bench`
/// does (make_case, prepare_case, doppler_points(s, c, 2.5)), and measures, for every Doppler
/// point, the vector to the nearest point of a reference centreline, projected normal to it:
///   tree     the phantom's true vessel tree (preop/vessels.vtp) moved by the truth displacement
///            (truth/displacement.nii.gz, trilinear): the Doppler extraction's own error;
///   skeleton the model's pre-operative skeleton (MRA extraction, fitted to the mesh) moved by
///            the truth: the error a perfect registration would see in its vessel rows;
///   rigid    the model's skeleton moved by rigid_only();
///   ours     the skeleton moved by the default loop (constraint_icp);
///   cv_1se   the skeleton moved by the block-CV loop with the one-SE rule.
/// Also, at the same skeleton points, the error of each registration against the truth (how far
/// the registration moved the vessels away from where they are), and how it follows the data
/// error. Positions world RAS mm; probe frame = (lateral 1, lateral 2, beam axis into tissue).
/// Usage: doppler_bias CASE SEED WORK_DIR [REAL_DATA]  (cases without a tracking error only).
/// Prints a plain-text report. Not shipped: a measurement tool.

#include "apps/bench/baselines.hpp"
#include "apps/bench/bench_run.hpp"
#include "apps/workflow/intraop_frame.hpp"
#include "apps/workflow/session.hpp"
#include "core/mapping/barycentric_mapping.hpp"
#include "data_synth/images/probe.hpp"
#include "imaging/filters/trilinear.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/skeleton_io.hpp"
#include "imaging/vessels/vessel_extraction.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

using namespace brainshift;
using namespace brainshift::workflow;

namespace {

struct Lines {
  MatrixX3d p;
  std::vector<std::array<index_t, 2>> seg;
  Eigen::VectorXd radius;
};

struct Nearest {
  double dist = 1e300;
  index_t seg = -1;
  double t = 0;
  Vector3d q, tangent;
};

Nearest nearest(const Lines& l, const Vector3d& x) {
  Nearest best;
  for (std::size_t s = 0; s < l.seg.size(); ++s) {
    const Vector3d a = l.p.row(l.seg[s][0]), b = l.p.row(l.seg[s][1]);
    const Vector3d ab = b - a;
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0 ? std::clamp((x - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const Vector3d q = a + t * ab;
    const double d = (x - q).norm();
    if (d < best.dist) {
      best = {d, index_t(s), t, q, len2 > 0 ? Vector3d(ab / std::sqrt(len2)) : Vector3d::UnitX()};
    }
  }
  return best;
}

Vector3d at(const Lines& l, const Nearest& n) {
  const Vector3d a = l.p.row(l.seg[std::size_t(n.seg)][0]),
                 b = l.p.row(l.seg[std::size_t(n.seg)][1]);
  return a + n.t * (b - a);
}

/// Turning angle per mm at segment s (degrees/mm): mean over its two ends' neighbours.
double curvature(const Lines& l, index_t s, const std::vector<std::vector<index_t>>& segs_at) {
  const auto [a, b] = l.seg[std::size_t(s)];
  const Vector3d d = (l.p.row(b) - l.p.row(a)).normalized();
  double sum = 0;
  int n = 0;
  for (const index_t end : {a, b})
    for (const index_t o : segs_at[std::size_t(end)]) {
      if (o == s) continue;
      const auto [c, e] = l.seg[std::size_t(o)];
      Vector3d f = (l.p.row(e) - l.p.row(c)).normalized();
      const double len =
          0.5 * ((l.p.row(e) - l.p.row(c)).norm() + (l.p.row(b) - l.p.row(a)).norm());
      const double ang = std::acos(std::clamp(std::abs(f.dot(d)), 0.0, 1.0)) * 180.0 / M_PI;
      sum += ang / std::max(len, 1e-6);
      ++n;
    }
  return n ? sum / n : 0.0;
}

struct Acc {
  Vector3d sum = Vector3d::Zero();
  double sq = 0;
  int n = 0;
  void add(const Vector3d& v) { sum += v, sq += v.squaredNorm(), ++n; }
  Vector3d mean() const { return n ? Vector3d(sum / n) : Vector3d::Zero(); }
  double rms() const { return n ? std::sqrt(sq / n) : 0.0; }
};

std::string fmt(const Vector3d& v) {
  char b[96];
  std::snprintf(b, sizeof b, "(%+.2f %+.2f %+.2f)", v.x(), v.y(), v.z());
  return b;
}

/// Affine fit of the vectors v_i against positions x_i: share of Σ|v|² explained by a constant
/// and by an affine field (least squares per component).
std::pair<double, double> explained(const std::vector<Vector3d>& x,
                                    const std::vector<Vector3d>& v) {
  const int n = int(x.size());
  if (n < 8) return {0, 0};
  Eigen::MatrixXd A(n, 4), V(n, 3);
  for (int i = 0; i < n; ++i) {
    A.row(i) << 1.0, x[std::size_t(i)].transpose();
    V.row(i) = v[std::size_t(i)].transpose();
  }
  const double total = V.squaredNorm();
  const Eigen::MatrixXd c1 = A.leftCols(1).colPivHouseholderQr().solve(V);
  const Eigen::MatrixXd c4 = A.colPivHouseholderQr().solve(V);
  return {1.0 - (V - A.leftCols(1) * c1).squaredNorm() / total,
          1.0 - (V - A * c4).squaredNorm() / total};
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 4) {
    std::cerr << "usage: doppler_bias CASE SEED WORK_DIR [REAL_DATA]\n";
    return 1;
  }
  const std::string name = argv[1];
  const auto seed = std::uint32_t(std::stoul(argv[2]));
  const std::filesystem::path work = argv[3];
  const std::filesystem::path real = argc > 4 ? argv[4] : "../shared/data";
  std::filesystem::create_directories(work);
  const CaseData c = make_case(name, seed, work / "phantom", real);
  (void)prepare_case(c, work / "model", 1.0);
  Session s = open_session(work / "model");
  const nlohmann::json cj = nlohmann::json::parse(std::ifstream(c.phantom / "case.json"));
  const auto& tr = cj["parameters"]["tracking_error"];
  const bool tracked = tr["translation_mm"] != nlohmann::json::array({0.0, 0.0, 0.0}) ||
                       tr["rotation_deg"] != nlohmann::json::array({0.0, 0.0, 0.0});
  if (tracked) std::cout << "WARNING: tracking error in this case; frames not reconciled\n";
  const Vector3d face(cj["probe"]["face_centre_mm"][0], cj["probe"]["face_centre_mm"][1],
                      cj["probe"]["face_centre_mm"][2]);
  const Vector3d axis(cj["probe"]["axis"][0], cj["probe"]["axis"][1], cj["probe"]["axis"][2]);
  const data_synth::Probe probe = data_synth::make_probe(face, axis, {});
  const Matrix3d F = probe.frame;  // columns: lateral 1, lateral 2, beam

  // Doppler points exactly as bench feeds them, and their graph (for neighbours and branches).
  const MatrixX3d dop = doppler_points(s, c, 2.5);
  imaging::VesselExtractionOptions vo;
  vo.resample_step_mm = 2.5;
  const imaging::VolumeF dimg = imaging::read_volume(c.phantom / "intraop/doppler.nii.gz");
  const core::Skeleton dsk = imaging::to_skeleton(imaging::extract_vessels(dimg, vo).graph);
  BS_VERIFY(dsk.points.rows() == dop.rows() && (dsk.points - dop).norm() < 1e-9,
            "the Doppler graph differs from doppler_points()");
  std::vector<int> branch_of(std::size_t(dop.rows()), -1);
  {
    const imaging::VesselGraph g = imaging::extract_vessels(dimg, vo).graph;
    // to_skeleton: nodes first, then each branch's interior points in order.
    index_t k = index_t(g.nodes.size());
    for (std::size_t b = 0; b < g.branches.size(); ++b)
      for (std::size_t i = 1; i + 1 < g.branches[b].points.size(); ++i)
        branch_of[std::size_t(k++)] = int(b);
  }

  // Truth displacement.
  const imaging::VolumeF disp = imaging::read_volume(c.phantom / "truth/displacement.nii.gz");
  auto u = [&](const Vector3d& X) {
    const Vector3d ijk = disp.geometry.world_to_index(X);
    Vector3d r;
    for (int k = 0; k < 3; ++k)
      r[k] = imaging::filters::sample_trilinear(disp, ijk, imaging::filters::MissingData::CLAMP, k);
    return r;
  };
  auto moved_by_truth = [&](const Lines& l) {
    Lines m = l;
    for (index_t i = 0; i < m.p.rows(); ++i) m.p.row(i) += u(l.p.row(i).transpose()).transpose();
    return m;
  };
  Lines tree_rest;
  {
    const core::Skeleton t =
        imaging::to_skeleton(imaging::read_skeleton_vtp(c.phantom / "preop/vessels.vtp"));
    tree_rest = {t.points, t.segments, t.radius};
  }
  const core::Skeleton& ms = s.model->skeleton();
  const Lines skel_rest{ms.points, ms.segments, ms.radius};
  std::map<std::string, Lines> ref;
  ref["tree"] = moved_by_truth(tree_rest);
  ref["skeleton"] = moved_by_truth(skel_rest);

  // Registrations.
  constraints::IntraopData data;
  data.vessel_points = dop;
  const constraints::RegistrationOptions o = product_options(s);
  constraints::RegistrationOptions cv = o;
  cv.noise.enabled = true;
  cv.global_start.bulk_response = false;
  cv.noise.one_standard_error = true;
  core::MappingOptions mo;
  mo.max_outside_distance = 20.0;
  const core::BarycentricMapping map(s.model->mesh(), ms.points, mo);
  const std::map<std::string, constraints::RegistrationResult> results = {
      {"rigid", rigid_only(*s.model, data, o)},
      {"ours", constraints::register_model(*s.model, data, o)},
      {"cv_1se", constraints::register_model(*s.model, data, cv)}};
  for (const auto& [k, r] : results) {
    Lines l = skel_rest;
    l.p = to_intraop_frame(r, map.apply(r.positions));
    ref[k] = l;
  }

  // Sanity: the model skeleton at rest against the true tree at rest.
  {
    Acc a;
    for (index_t i = 0; i < skel_rest.p.rows(); ++i) {
      const Nearest n = nearest(tree_rest, skel_rest.p.row(i).transpose());
      if (n.dist > 5) continue;
      const Vector3d v = skel_rest.p.row(i).transpose() - n.q;
      a.add(v - v.dot(n.tangent) * n.tangent);
    }
    std::printf("%s seed %u: model skeleton (rest) vs true tree (rest): n=%d mean %s rms %.2f\n",
                name.c_str(), seed, a.n, fmt(a.mean()).c_str(), a.rms());
  }
  std::printf("Doppler points %ld; probe face %s axis %s\n", long(dop.rows()), fmt(face).c_str(),
              fmt(axis).c_str());

  std::vector<std::vector<index_t>> segs_at_tree(std::size_t(tree_rest.p.rows()));
  for (std::size_t k = 0; k < tree_rest.seg.size(); ++k)
    for (const index_t e : tree_rest.seg[k]) segs_at_tree[std::size_t(e)].push_back(index_t(k));

  // Optional per-point dump (env DOPPLER_BIAS_CSV): the Doppler point in the probe frame, the true
  // tree's radius there, the FoV margin of the drawn tube, and the normal error against the tree.
  if (const char* csv = std::getenv("DOPPLER_BIAS_CSV")) {
    std::ofstream out(csv);
    out << "i,branch,depth,lat1,lat2,tree_depth,tree_lat,radius,margin_top,margin_side,e1,e2,e3,"
           "dist\n";
    const double tan_a = std::tan(probe.options.half_angle_deg * M_PI / 180.0);
    for (index_t i = 0; i < dop.rows(); ++i) {
      const Vector3d p = dop.row(i).transpose();
      const Nearest n = nearest(ref.at("tree"), p);
      const auto [a, b] = tree_rest.seg[std::size_t(n.seg)];
      const double r = (1 - n.t) * tree_rest.radius[a] + n.t * tree_rest.radius[b];
      const double drawn = 1.4 * r + 0.4;  // DopplerOptions thickening (defaults)
      const Vector3d q = F.transpose() * (p - face), qt = F.transpose() * (n.q - face);
      const double lat_t = qt.head<2>().norm();
      const double side =
          (probe.options.footprint_radius + qt.z() * tan_a - lat_t) / std::sqrt(1 + tan_a * tan_a);
      Vector3d v = p - n.q;
      v -= v.dot(n.tangent) * n.tangent;
      const Vector3d vp = F.transpose() * v;
      out << i << ',' << branch_of[std::size_t(i)] << ',' << q.z() << ',' << q.x() << ',' << q.y()
          << ',' << qt.z() << ',' << lat_t << ',' << r << ',' << qt.z() - drawn << ','
          << side - drawn << ',' << vp.x() << ',' << vp.y() << ',' << vp.z() << ',' << n.dist
          << '\n';
    }
  }

  for (const std::string key : {"tree", "skeleton", "rigid", "ours", "cv_1se"}) {
    const Lines& l = ref.at(key);
    Acc all, probe_frame;
    std::map<std::string, Acc> bins;
    std::vector<Vector3d> xs, vs;
    std::vector<Vector3d> vn(std::size_t(dop.rows()), Vector3d::Constant(NAN));
    int far = 0;
    for (index_t i = 0; i < dop.rows(); ++i) {
      const Vector3d p = dop.row(i).transpose();
      const Nearest n = nearest(l, p);
      if (n.dist > 5.0) {
        ++far;
        continue;
      }
      Vector3d v = p - n.q;
      v -= v.dot(n.tangent) * n.tangent;
      vn[std::size_t(i)] = v;
      all.add(v);
      const Vector3d vp = F.transpose() * v;
      probe_frame.add(vp);
      xs.push_back(p);
      vs.push_back(v);
      const Vector3d q = F.transpose() * (p - face);
      const double depth = q.z(), lat = q.head<2>().norm();
      bins[depth < 10   ? "depth 0-10"
           : depth < 20 ? "depth 10-20"
           : depth < 35 ? "depth 20-35"
                        : "depth 35+"]
          .add(vp);
      // radial lateral component: positive = away from the beam axis
      const Vector3d radial_dir =
          lat > 1e-6 ? Vector3d(F * Vector3d(q.x(), q.y(), 0) / lat) : Vector3d::Zero();
      bins[lat < 10   ? "lat 0-10"
           : lat < 20 ? "lat 10-20"
                      : "lat 20+"]
          .add(Vector3d(v.dot(radial_dir), 0, vp.z()));
      // radius and curvature of the true tree at the nearest point
      const Nearest nt = nearest(ref.at("tree"), p);
      if (nt.dist <= 5.0) {
        const auto [a, b] = tree_rest.seg[std::size_t(nt.seg)];
        const double r = (1 - nt.t) * tree_rest.radius[a] + nt.t * tree_rest.radius[b];
        bins[r < 1.0 ? "radius <1" : r < 1.8 ? "radius 1-1.8" : "radius 1.8+"].add(vp);
        const double k = curvature(ref.at("tree"), nt.seg, segs_at_tree);
        bins[k < 4 ? "curv <4deg/mm" : k < 10 ? "curv 4-10deg/mm" : "curv 10+deg/mm"].add(vp);
      }
    }
    const auto [e1, e4] = explained(xs, vs);
    std::printf(
        "\n[%s] n=%d (far>5mm %d)  normal error: mean %s world, %s probe (lat1 lat2 beam), "
        "|mean| %.2f, rms %.2f; share of sum|v|^2 explained: constant %.2f, affine %.2f\n",
        key.c_str(), all.n, far, fmt(all.mean()).c_str(), fmt(probe_frame.mean()).c_str(),
        all.mean().norm(), all.rms(), e1, e4);
    for (const auto& [b, a] : bins)
      std::printf("   %-16s n=%3d mean %s rms %.2f%s\n", b.c_str(), a.n, fmt(a.mean()).c_str(),
                  a.rms(), b.rfind("lat", 0) == 0 ? "   (radial-out, 0, beam)" : "");
    // Correlation between neighbouring Doppler points (segments of the Doppler graph) and
    // between-branch share.
    double num = 0, den = 0, cnum = 0, cden = 0;
    const Vector3d m = all.mean();
    for (const auto& [a, b] : dsk.segments) {
      const Vector3d va = vn[std::size_t(a)], vb = vn[std::size_t(b)];
      if (!va.allFinite() || !vb.allFinite()) continue;
      num += va.dot(vb);
      den += 0.5 * (va.squaredNorm() + vb.squaredNorm());
      cnum += (va - m).dot(vb - m);
      cden += 0.5 * ((va - m).squaredNorm() + (vb - m).squaredNorm());
    }
    std::map<int, Acc> per_branch;
    for (std::size_t i = 0; i < vn.size(); ++i)
      if (vn[i].allFinite()) per_branch[branch_of[i]].add(vn[i]);
    double between = 0, total = 0;
    for (const auto& [b, a] : per_branch) {
      between += a.n * (a.mean() - m).squaredNorm();
      total += a.sq - 2 * a.sum.dot(m) + a.n * m.squaredNorm();
    }
    std::printf(
        "   neighbour correlation %.2f (centred %.2f); between-branch share of the "
        "centred variance %.2f over %zu branches\n",
        den > 0 ? num / den : 0.0, cden > 0 ? cnum / cden : 0.0, total > 0 ? between / total : 0.0,
        per_branch.size());
  }

  // Where the registrations put the vessels: at the skeleton point nearest each Doppler point,
  // result − truth (normal to the vessel), and its regression on the data error there.
  std::printf("\nregistration error at the paired skeleton points (result - truth, normal):\n");
  const Lines& truth_sk = ref.at("skeleton");
  for (const std::string key : {"rigid", "ours", "cv_1se"}) {
    Acc e;
    double sxy = 0, sxx = 0;
    for (index_t i = 0; i < dop.rows(); ++i) {
      const Vector3d p = dop.row(i).transpose();
      const Nearest n = nearest(truth_sk, p);
      if (n.dist > 5.0) continue;
      Vector3d d = p - n.q;
      d -= d.dot(n.tangent) * n.tangent;  // data error
      Vector3d err = at(ref.at(key), n) - n.q;
      err -= err.dot(n.tangent) * n.tangent;
      e.add(err);
      sxy += err.dot(d);
      sxx += d.squaredNorm();
    }
    std::printf("   %-7s n=%d mean %s rms %.2f; slope on the data error %.2f  (%s)\n", key.c_str(),
                e.n, fmt(e.mean()).c_str(), e.rms(), sxx > 0 ? sxy / sxx : 0.0,
                constraints::to_string(results.at(key).stop).c_str());
  }
  return 0;
} catch (const std::exception& e) {
  std::cerr << "doppler_bias: " << e.what() << '\n';
  return 1;
}
