#include "apps/bench/bench_dense.hpp"

#include "apps/workflow/intraop_frame.hpp"
#include "core/error.hpp"
#include "core/mapping/barycentric_mapping.hpp"
#include "data_synth/images/probe.hpp"
#include "imaging/filters/trilinear.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/image_io.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <random>

namespace brainshift::workflow {

DenseTruth dense_truth(const std::filesystem::path& phantom, const imaging::LandmarkPairs& truth,
                       int count, std::uint32_t seed) {
  DenseTruth out;
  try {
    const imaging::LabelVolume labels = imaging::read_labels(phantom / "preop/labels.nii.gz");
    const imaging::VolumeF u = imaging::read_volume(phantom / "truth/displacement.nii.gz");
    if (u.components != 3 || u.geometry.size != labels.geometry.size ||
        !u.geometry.origin.isApprox(labels.geometry.origin, 1e-6)) {
      out.note = "the truth field is not a 3-component field on the labels' grid";
      return out;
    }
    // The truth frame (case.json): the world, or the intra-operative images' frame (the case's
    // tracking offset about the probe's face centre) when the case writes its truth there.
    std::ifstream in(phantom / "case.json");
    const nlohmann::json cj = nlohmann::json::parse(in);
    const nlohmann::json& te = cj.at("parameters").at("tracking_error");
    data_synth::TrackingError tracking;
    Vector3d pivot = Vector3d::Zero();
    const bool image_frame = te.at("truth_in_image_frame").get<bool>();
    if (image_frame) {
      for (int c = 0; c < 3; ++c) {
        tracking.translation[c] = te.at("translation_mm").at(c).get<double>();
        tracking.rotation_deg[c] = te.at("rotation_deg").at(c).get<double>();
        pivot[c] = cj.at("probe").at("face_centre_mm").at(c).get<double>();
      }
    }
    const auto to_truth = [&](const Vector3d& x) {
      return image_frame ? tracking.apply(x, pivot) : x;
    };
    const auto displaced = [&](const Vector3d& x) {
      const Vector3d ijk = u.geometry.world_to_index(x);
      Vector3d d;
      for (int c = 0; c < 3; ++c)
        d[c] = imaging::filters::sample_trilinear(u, ijk, imaging::filters::MissingData::CLAMP, c);
      return Vector3d(x + d);
    };
    // Check: the landmarks' X + u(X) in that frame against their written positions (the field is
    // the TLED one rasterised on the 1 mm grid, the landmarks the TLED one itself).
    double sq = 0.0;
    for (Eigen::Index i = 0; i < truth.a.rows(); ++i)
      sq += (to_truth(displaced(truth.a.row(i).transpose())) - truth.b.row(i).transpose())
                .squaredNorm();
    out.frame_fit_rms_mm = std::sqrt(sq / static_cast<double>(truth.a.rows()));
    if (!(out.frame_fit_rms_mm <= 0.5)) {
      out.note = "the truth field does not reproduce the landmarks (RMS " +
                 std::to_string(out.frame_fit_rms_mm) + " mm)";
      return out;
    }
    std::vector<std::int64_t> brain;
    for (std::int64_t v = 0; v < labels.geometry.voxel_count(); ++v)
      if (labels.data[std::size_t(v)] != imaging::BACKGROUND) brain.push_back(v);
    if (brain.empty()) {
      out.note = "no brain voxels";
      return out;
    }
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::size_t> pick(0, brain.size() - 1);
    out.pre.resize(count, 3);
    out.intra.resize(count, 3);
    const Eigen::Vector3i& n = labels.geometry.size;
    for (int p = 0; p < count; ++p) {
      const std::int64_t v = brain[pick(rng)];
      const int i = int(v % n[0]), j = int((v / n[0]) % n[1]),
                k = int(v / (std::int64_t(n[0]) * n[1]));
      const Vector3d x = labels.geometry.index_to_world(Vector3d(i, j, k));
      const Vector3d d(u.at(i, j, k, 0), u.at(i, j, k, 1), u.at(i, j, k, 2));
      out.pre.row(p) = x.transpose();
      out.intra.row(p) = to_truth(x + d).transpose();
    }
  } catch (const std::exception& e) {
    out = DenseTruth{};
    out.note = e.what();
  }
  return out;
}

DenseScore dense_score(const core::TetMesh& mesh, const constraints::UncertaintyResult& u,
                       const constraints::RegistrationResult& r, ConstRef<MatrixX3d> pre,
                       ConstRef<MatrixX3d> intra, ConstRef<MatrixX3d> vessel_points) {
  BS_VERIFY(pre.rows() == intra.rows(),
            "dense calibration: " << pre.rows() << " points and " << intra.rows() << " truths");
  DenseScore s;
  s.s2 = u.s2;
  core::MappingOptions mo;
  mo.max_outside_distance = 1e9;  // a point just outside the mesh takes its nearest tetrahedron
  const core::BarycentricMapping map(mesh, pre, mo);
  const Eigen::VectorXd var = (map.matrix() * u.node_variance).cwiseMax(0.0);
  const Eigen::VectorXd track = u.node_tracking.size() == u.node_variance.size()
                                    ? Eigen::VectorXd(map.matrix() * u.node_tracking)
                                    : Eigen::VectorXd::Zero(pre.rows());
  const MatrixX3d predicted = to_intraop_frame(r, map.apply(r.positions));
  s.actual = imaging::landmark_errors(predicted, intra);
  double sn = 0, sf = 0, an = 0, af = 0;
  for (Eigen::Index i = 0; i < pre.rows(); ++i) {
    s.sigma.push_back(std::sqrt(var[i]));
    s.tracking.push_back(track[i]);
    s.unscaled.push_back(u.s2 > 0 ? std::max(0.0, var[i] - track[i]) / u.s2 : 0.0);
    const double d = vessel_points.rows() > 0
                         ? (vessel_points.rowwise() - intra.row(i)).rowwise().norm().minCoeff()
                         : std::numeric_limits<double>::infinity();
    s.distance.push_back(d);
    if (d <= 5.0) sn += s.sigma.back(), an += s.actual[std::size_t(i)], ++s.near;
    if (d > 10.0) sf += s.sigma.back(), af += s.actual[std::size_t(i)], ++s.far;
  }
  s.cal = imaging::calibrate_uncertainty(s.sigma, s.actual);
  s.near_predicted_mm = s.near ? sn / s.near : std::nan("");
  s.near_actual_mm = s.near ? an / s.near : std::nan("");
  s.far_predicted_mm = s.far ? sf / s.far : std::nan("");
  s.far_actual_mm = s.far ? af / s.far : std::nan("");
  return s;
}

void write_dense_csv(const std::filesystem::path& path, const DenseScore* landmarks,
                     ConstRef<MatrixX3d> landmark_points, ConstRef<MatrixX3d> landmark_truth,
                     const DenseScore* dense, ConstRef<MatrixX3d> dense_points,
                     ConstRef<MatrixX3d> dense_truth) {
  imaging::write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream f(tmp);
    f << "kind,x,y,z,sigma_mm,unscaled_var,tracking_var_mm2,actual_mm,distance_mm,s2,truth_shift_"
         "mm\n"
      << std::setprecision(7);
    auto rows = [&](const char* kind, const DenseScore* s, ConstRef<MatrixX3d> p,
                    ConstRef<MatrixX3d> t) {
      if (!s || p.rows() != Eigen::Index(s->sigma.size()) || t.rows() != p.rows()) return;
      for (std::size_t i = 0; i < s->sigma.size(); ++i)
        f << kind << ',' << p(Eigen::Index(i), 0) << ',' << p(Eigen::Index(i), 1) << ','
          << p(Eigen::Index(i), 2) << ',' << s->sigma[i] << ',' << s->unscaled[i] << ','
          << s->tracking[i] << ',' << s->actual[i] << ',' << s->distance[i] << ',' << s->s2 << ','
          << (t.row(Eigen::Index(i)) - p.row(Eigen::Index(i))).norm() << '\n';
    };
    rows("landmark", landmarks, landmark_points, landmark_truth);
    rows("dense", dense, dense_points, dense_truth);
    BS_VERIFY(f.good(), tmp.string() << ": write failed");
  });
}

}  // namespace brainshift::workflow
