// The two displacement fields brainshift register writes for 3D Slicer, read back the way Slicer
// (through ITK) reads them — with a NRRD parser written here, not brainshift's reader — and
// applied in ITK's sense: a displacement-field transform maps a point p of its grid's space to
// p + v(p) (LPS, trilinear), and Slicer uses it as the node's "transform from parent". So:
//   preop_to_intraop.nrrd: y + v(y) is the pre-operative point now at y (content moves to where
//                          it is now); checked on the phantom's intra-operative landmarks;
//   intraop_to_preop.nrrd: X + v(X) is where the pre-operative point X is now; checked on the
//                          pre-operative landmarks.
// Both must map the truth landmarks within the registration's own TRE (brainshift evaluate) plus
// 0.3 mm, and be each other's inverse.

#include "cli_helpers.hpp"

#include "imaging/io/csv.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>
#include <zlib.h>

namespace brainshift {
namespace {

/// A 3-D vector field as ITK reads a NRRD: LPS physical space, index → point p = o + D i.
struct ItkField {
  std::map<std::string, std::string> fields;
  std::array<long, 3> size{};
  Eigen::Matrix3d D;  ///< columns: space directions of the three domain axes (mm, LPS)
  Eigen::Vector3d origin;
  std::vector<float> data;  ///< 3 components per voxel, i fastest

  /// v(p) by trilinear interpolation; zero outside the grid (ITK's DisplacementFieldTransform).
  [[nodiscard]] Eigen::Vector3d at(const Eigen::Vector3d& p_lps) const {
    const Eigen::Vector3d c = D.inverse() * (p_lps - origin);
    std::array<long, 3> i0{};
    std::array<double, 3> w{};
    for (int a = 0; a < 3; ++a) {
      if (!(c[a] >= 0.0 && c[a] <= double(size[std::size_t(a)] - 1)))
        return Eigen::Vector3d::Zero();
      i0[std::size_t(a)] = std::min(long(c[a]), size[std::size_t(a)] - 2);
      w[std::size_t(a)] = c[a] - double(i0[std::size_t(a)]);
    }
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    for (int corner = 0; corner < 8; ++corner) {
      double weight = 1.0;
      long offset = 0, stride = 1;
      for (int a = 0; a < 3; ++a) {
        const int bit = (corner >> a) & 1;
        weight *= bit ? w[std::size_t(a)] : 1.0 - w[std::size_t(a)];
        offset += (i0[std::size_t(a)] + bit) * stride;
        stride *= size[std::size_t(a)];
      }
      for (int k = 0; k < 3; ++k) v[k] += weight * double(data[std::size_t(3 * offset + k)]);
    }
    return v;
  }
};

Eigen::Vector3d parse_tuple(std::string text) {
  std::replace_if(
      text.begin(), text.end(), [](char c) { return c == '(' || c == ')' || c == ','; }, ' ');
  std::istringstream in(text);
  Eigen::Vector3d v;
  in >> v[0] >> v[1] >> v[2];
  return v;
}

ItkField read_field(const std::filesystem::path& path) {
  ItkField f;
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line.rfind("NRRD000", 0), 0U) << path;
  while (std::getline(in, line) && !line.empty()) {
    if (line[0] == '#') continue;
    const auto colon = line.find(": ");
    if (colon != std::string::npos) f.fields[line.substr(0, colon)] = line.substr(colon + 2);
  }
  // What Slicer needs to recognise a displacement field: a vector axis first, then the grid, LPS.
  EXPECT_EQ(f.fields["dimension"], "4");
  EXPECT_EQ(f.fields["kinds"], "vector domain domain domain");
  EXPECT_EQ(f.fields["space"], "left-posterior-superior");
  EXPECT_EQ(f.fields["type"], "float");
  EXPECT_EQ(f.fields["endian"], "little");
  std::istringstream sizes(f.fields["sizes"]);
  long components = 0;
  sizes >> components >> f.size[0] >> f.size[1] >> f.size[2];
  EXPECT_EQ(components, 3);
  std::istringstream dirs(f.fields["space directions"]);
  std::string none;
  dirs >> none;
  EXPECT_EQ(none, "none");
  for (int a = 0; a < 3; ++a) {
    std::string t;
    dirs >> t;
    f.D.col(a) = parse_tuple(t);
  }
  f.origin = parse_tuple(f.fields["space origin"]);
  const std::size_t count = std::size_t(3 * f.size[0] * f.size[1] * f.size[2]);
  f.data.resize(count);
  const std::vector<char> rest((std::istreambuf_iterator<char>(in)),
                               std::istreambuf_iterator<char>());
  if (f.fields["encoding"] == "raw") {
    EXPECT_EQ(rest.size(), count * sizeof(float)) << path;
    std::memcpy(f.data.data(), rest.data(), std::min(rest.size(), count * sizeof(float)));
  } else {
    EXPECT_EQ(f.fields["encoding"], "gzip");
    z_stream z{};
    inflateInit2(&z, 15 + 32);
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(rest.data()));
    z.avail_in = uInt(rest.size());
    z.next_out = reinterpret_cast<Bytef*>(f.data.data());
    z.avail_out = uInt(count * sizeof(float));
    EXPECT_EQ(inflate(&z, Z_FINISH), Z_STREAM_END) << path;
    inflateEnd(&z);
  }
  return f;
}

Eigen::Vector3d ras_to_lps(const Eigen::Vector3d& p) { return {-p.x(), -p.y(), p.z()}; }

/// Mean and max over landmarks of |p + v(p) − target| with p taken from `from`, all in RAS.
std::pair<double, double> mapping_error(const ItkField& f, const imaging::Landmarks& from,
                                        const imaging::Landmarks& to) {
  std::map<std::string, Eigen::Vector3d> target;
  for (std::size_t i = 0; i < to.ids.size(); ++i)
    target[to.ids[i]] = to.points.row(Eigen::Index(i)).transpose();
  double sum = 0.0, worst = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < from.ids.size(); ++i) {
    const auto it = target.find(from.ids[i]);
    if (it == target.end()) continue;
    const Eigen::Vector3d p = ras_to_lps(from.points.row(Eigen::Index(i)).transpose());
    const Eigen::Vector3d mapped = ras_to_lps(p + f.at(p));  // LPS ↔ RAS is its own inverse
    const double e = (mapped - it->second).norm();
    sum += e;
    worst = std::max(worst, e);
    ++n;
  }
  EXPECT_GT(n, 5) << "too few landmarks in common";
  return {sum / std::max(n, 1), worst};
}

TEST(SlicerTransforms, BothFieldsMapThePhantomLandmarksAsWellAsTheRegistration) {
  const tests::TempFolder dir;
  const auto ph = dir / "phantom", model = dir / "model", res = dir / "res";
  CliRun r = run_brainshift(dir, "phantom --case standard --seed 1 --out " + q(ph));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  r = run_brainshift(dir, "prepare --labels " + q(ph / "preop/labels.nii.gz") + " --mra " +
                              q(ph / "preop/mra.nii.gz") + " --out " + q(model));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  r = run_brainshift(dir, "register --model " + q(model) + " --doppler " +
                              q(ph / "intraop/doppler.nii.gz") + " --out " + q(res));
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 2) << r.out << r.err;
  r = run_brainshift(dir, "evaluate --result " + q(res) + " --landmarks-pre " +
                              q(ph / "truth/landmarks_preop.csv") + " --landmarks-intra " +
                              q(ph / "truth/landmarks_intraop.csv"));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto ev = nlohmann::json::parse(read_all(res / "evaluation.json"));
  const double tre_mean = ev["tre_after_mm"]["mean"].get<double>();
  const double tre_max = ev["tre_after_mm"]["max"].get<double>();
  const double shift_mean = ev["tre_before_mm"]["mean"].get<double>();

  const imaging::Landmarks pre = imaging::read_landmarks(ph / "truth/landmarks_preop.csv");
  const imaging::Landmarks intra = imaging::read_landmarks(ph / "truth/landmarks_intraop.csv");
  const ItkField to_intra = read_field(res / "preop_to_intraop.nrrd");
  const ItkField to_pre = read_field(res / "intraop_to_preop.nrrd");
  const auto [to_intra_mean, to_intra_max] = mapping_error(to_intra, intra, pre);
  const auto [to_pre_mean, to_pre_max] = mapping_error(to_pre, pre, intra);
  std::cout << "TRE after registration: mean " << tre_mean << " mm, max " << tre_max
            << " mm (before: mean " << shift_mean
            << " mm)\npreop_to_intraop.nrrd on the intra-operative landmarks: mean "
            << to_intra_mean << " mm, max " << to_intra_max
            << " mm\nintraop_to_preop.nrrd on the pre-operative landmarks: mean " << to_pre_mean
            << " mm, max " << to_pre_max << " mm\n";
  // The bound: the registration's TRE + 0.3 mm (trilinear interpolation between voxel
  // centres on the 1 mm grid, and for the inverse the map's local stretch times the TRE).
  constexpr double SLACK_MM = 0.3;
  // intraop_to_preop samples the same map as displacement.nii.gz, from which evaluate measures
  // the TRE, in the same space: every landmark within it.
  EXPECT_LE(to_pre_mean, tre_mean + SLACK_MM);
  EXPECT_LE(to_pre_max, tre_max + SLACK_MM);
  // preop_to_intraop measures the error in the pre-operative space, |φ⁻¹(y) − X| instead of
  // |y − φ(X)|: per landmark they differ by the local stretch of φ (measured on seed 1: 3.07 vs
  // 2.01 mm at one landmark, max 3.96 vs 3.57 mm), so the bound holds for the mean TRE, the
  // figure quoted everywhere (measured 1.85 vs 1.77 mm).
  EXPECT_LE(to_intra_mean, tre_mean + SLACK_MM);
  // And the files are each other's inverse: φ(φ⁻¹(y)) = y at every intra-operative landmark, up
  // to trilinear interpolation of two piecewise-linear fields on a 1 mm grid (measured ≤ 0.05 mm).
  constexpr double INVERSE_CONSISTENCY_MM = 0.1;
  for (Eigen::Index i = 0; i < intra.points.rows(); ++i) {
    const Eigen::Vector3d y = ras_to_lps(intra.points.row(i).transpose());
    const Eigen::Vector3d X = y + to_intra.at(y);
    EXPECT_LE((X + to_pre.at(X) - y).norm(), INVERSE_CONSISTENCY_MM) << intra.ids[std::size_t(i)];
  }
  // And they move content the right way: a field applied in the wrong sense would leave about
  // twice the shift (the issue measured 9.6 mm against 5.0 mm of shift); a third is far below.
  EXPECT_LT(to_intra_mean, shift_mean / 3.0);
}

}  // namespace
}  // namespace brainshift
