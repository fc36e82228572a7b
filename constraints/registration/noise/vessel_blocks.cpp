#include "constraints/registration/noise/vessel_blocks.hpp"

#include <cmath>

namespace brainshift::constraints {

std::vector<index_t> segment_blocks(const core::Skeleton& skeleton, double max_length_mm) {
  const auto& segs = skeleton.segments;
  const auto np = static_cast<std::size_t>(skeleton.points.rows());
  std::vector<std::vector<std::size_t>> incident(np);
  for (std::size_t s = 0; s < segs.size(); ++s)
    for (index_t v : segs[s])
      if (v >= 0 && static_cast<std::size_t>(v) < np)
        incident[static_cast<std::size_t>(v)].push_back(s);
  auto length = [&](std::size_t s) {
    const index_t a = segs[s][0], b = segs[s][1];
    if (a < 0 || b < 0 || static_cast<std::size_t>(a) >= np || static_cast<std::size_t>(b) >= np)
      return 0.0;
    const double l = (skeleton.points.row(a) - skeleton.points.row(b)).norm();
    return std::isfinite(l) ? l : 0.0;
  };
  std::vector<index_t> block(segs.size(), -1);
  index_t next = 0;
  // Walks a chain from segment `s` entered at point `from`, through points of degree 2.
  auto walk = [&](std::size_t s, index_t from) {
    double run = 0.0;
    for (;;) {
      const double l = length(s);
      if (max_length_mm > 0 && run > 0 && run + 0.5 * l > max_length_mm) {
        ++next;
        run = 0.0;
      }
      block[s] = next;
      run += l;
      const index_t to = segs[s][0] == from ? segs[s][1] : segs[s][0];
      if (to < 0 || static_cast<std::size_t>(to) >= np) break;
      const auto& inc = incident[static_cast<std::size_t>(to)];
      if (inc.size() != 2) break;  // an end or a junction ends the branch
      const std::size_t t = inc[0] == s ? inc[1] : inc[0];
      if (block[t] >= 0) break;  // back where the chain started (a cycle)
      s = t;
      from = to;
    }
    ++next;
  };
  // Chains starting at ends and junctions first, then what is left (cycles).
  for (std::size_t v = 0; v < np; ++v)
    if (incident[v].size() != 2)
      for (std::size_t s : incident[v])
        if (block[s] < 0) walk(s, static_cast<index_t>(v));
  for (std::size_t s = 0; s < segs.size(); ++s)
    if (block[s] < 0) walk(s, segs[s][0]);
  return block;
}

}  // namespace brainshift::constraints
