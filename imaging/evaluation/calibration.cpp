#include "imaging/evaluation/calibration.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace brainshift::imaging {
namespace {

std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<std::size_t> order(v.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j + 1 < order.size() && v[order[j + 1]] == v[order[i]]) ++j;
    const double avg = 0.5 * static_cast<double>(i + j) + 1.0;
    for (std::size_t k = i; k <= j; ++k) r[order[k]] = avg;
    i = j + 1;
  }
  return r;
}

}  // namespace

double spearman(const std::vector<double>& a, const std::vector<double>& b) {
  BS_VERIFY(a.size() == b.size(), "spearman: " << a.size() << " and " << b.size() << " values");
  if (a.size() < 2) return 0.0;
  const std::vector<double> ra = ranks(a), rb = ranks(b);
  const double n = static_cast<double>(a.size());
  const double ma = std::accumulate(ra.begin(), ra.end(), 0.0) / n,
               mb = std::accumulate(rb.begin(), rb.end(), 0.0) / n;
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < ra.size(); ++i) {
    sab += (ra[i] - ma) * (rb[i] - mb);
    saa += (ra[i] - ma) * (ra[i] - ma);
    sbb += (rb[i] - mb) * (rb[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0.0;
}

std::pair<double, double> per_axis_within_sigma_pct(const std::vector<double>& predicted_mm,
                                                    ConstRef<MatrixX3d> error_mm) {
  BS_VERIFY(static_cast<Eigen::Index>(predicted_mm.size()) == error_mm.rows(),
            "uncertainty calibration: " << predicted_mm.size() << " predicted errors and "
                                        << error_mm.rows() << " error vectors");
  if (predicted_mm.empty()) return {0.0, 0.0};
  int in1 = 0, in2 = 0;
  for (std::size_t i = 0; i < predicted_mm.size(); ++i) {
    const double s = predicted_mm[i] / std::sqrt(3.0);
    BS_VERIFY(std::isfinite(s) && s >= 0 && error_mm.row(Eigen::Index(i)).allFinite(),
              "uncertainty calibration: error " << i << " is negative or not finite");
    for (int c = 0; c < 3; ++c) {
      const double e = std::abs(error_mm(Eigen::Index(i), c));
      in1 += e <= s;
      in2 += e <= 2 * s;
    }
  }
  const double n = 3.0 * static_cast<double>(predicted_mm.size());
  return {100.0 * in1 / n, 100.0 * in2 / n};
}

UncertaintyCalibration calibrate_uncertainty(const std::vector<double>& predicted_mm,
                                             const std::vector<double>& actual_mm) {
  BS_VERIFY(predicted_mm.size() == actual_mm.size(),
            "uncertainty calibration: " << predicted_mm.size() << " predicted and "
                                        << actual_mm.size() << " actual errors");
  UncertaintyCalibration c;
  c.count = static_cast<int>(predicted_mm.size());
  if (c.count == 0) return c;
  int in1 = 0, in2 = 0;
  double ratio2 = 0.0;
  int ratios = 0;
  for (std::size_t i = 0; i < predicted_mm.size(); ++i) {
    const double p = predicted_mm[i], a = actual_mm[i];
    BS_VERIFY(std::isfinite(p) && std::isfinite(a) && p >= 0 && a >= 0,
              "uncertainty calibration: error " << i << " is negative or not finite (" << p << ", "
                                                << a << ")");
    in1 += a <= p;
    in2 += a <= 2 * p;
    c.mean_predicted_mm += p;
    c.mean_actual_mm += a;
    if (p > 0) ratio2 += (a / p) * (a / p), ++ratios;
  }
  const double n = c.count;
  c.within_1_sigma_pct = 100.0 * in1 / n;
  c.within_2_sigma_pct = 100.0 * in2 / n;
  c.mean_predicted_mm /= n;
  c.mean_actual_mm /= n;
  c.rms_ratio = ratios ? std::sqrt(ratio2 / ratios) : 0.0;
  c.spearman = spearman(predicted_mm, actual_mm);
  return c;
}

}  // namespace brainshift::imaging
