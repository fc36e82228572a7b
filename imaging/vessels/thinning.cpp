#include "imaging/vessels/thinning.hpp"

#include <array>
#include <vector>

namespace brainshift::imaging {
namespace {

/// The 26 neighbour offsets (dx, dy, dz), in a fixed order, and their adjacency tables.
struct Neighbourhood {
  std::array<std::array<int, 3>, 26> offset{};
  std::array<std::uint32_t, 26> adjacent26{};  ///< bitmask of 26-adjacent neighbours
  std::array<std::uint32_t, 26> adjacent6{};   ///< bitmask of 6-adjacent neighbours
  std::uint32_t n18 = 0;                       ///< face and edge neighbours
  std::uint32_t n6 = 0;                        ///< face neighbours

  Neighbourhood() {
    int b = 0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (dx != 0 || dy != 0 || dz != 0) offset[std::size_t(b++)] = {dx, dy, dz};
    for (std::size_t a = 0; a < 26; ++a) {
      const int l1 = std::abs(offset[a][0]) + std::abs(offset[a][1]) + std::abs(offset[a][2]);
      if (l1 <= 2) n18 |= 1u << a;
      if (l1 == 1) n6 |= 1u << a;
      for (std::size_t c = 0; c < 26; ++c) {
        if (a == c) continue;
        int cheb = 0, man = 0;
        for (int k = 0; k < 3; ++k) {
          const int d = std::abs(offset[a][std::size_t(k)] - offset[c][std::size_t(k)]);
          cheb = std::max(cheb, d);
          man += d;
        }
        if (cheb == 1) adjacent26[a] |= 1u << c;
        if (man == 1) adjacent6[a] |= 1u << c;
      }
    }
  }
};

const Neighbourhood& neighbourhood() {
  static const Neighbourhood n;
  return n;
}

/// Number of connected components of the set `set` under the adjacency table `adjacent`; stops
/// counting at 2.
int components(std::uint32_t set, const std::array<std::uint32_t, 26>& adjacent) {
  int count = 0;
  while (set != 0) {
    if (++count > 1) return count;
    std::uint32_t frontier = set & (~set + 1);  // lowest set bit
    std::uint32_t reached = frontier;
    while (frontier != 0) {
      const int b = __builtin_ctz(frontier);
      frontier &= frontier - 1;
      const std::uint32_t next = adjacent[std::size_t(b)] & set & ~reached;
      reached |= next;
      frontier |= next;
    }
    set &= ~reached;
  }
  return count;
}

/// (26, 6) simple-point test on the 26-neighbour foreground bitmask `fg`.
bool is_simple(std::uint32_t fg) {
  const Neighbourhood& nb = neighbourhood();
  if (components(fg, nb.adjacent26) != 1) return false;
  // Background 6-components within N18 that touch a face neighbour.
  std::uint32_t bg = ~fg & nb.n18 & ((1u << 26) - 1);
  int touching = 0;
  while (bg != 0) {
    std::uint32_t frontier = bg & (~bg + 1);
    std::uint32_t reached = frontier;
    while (frontier != 0) {
      const int b = __builtin_ctz(frontier);
      frontier &= frontier - 1;
      const std::uint32_t next = nb.adjacent6[std::size_t(b)] & bg & ~reached;
      reached |= next;
      frontier |= next;
    }
    if ((reached & nb.n6) != 0 && ++touching > 1) return false;
    bg &= ~reached;
  }
  return touching == 1;
}

}  // namespace

ThinningReport thin_to_curves(Volume<std::uint8_t>& mask) {
  BS_VERIFY(mask.components == 1, "thinning needs a one-component mask, got " << mask.components);
  const Eigen::Vector3i n = mask.geometry.size;
  for (auto& v : mask.data) v = v != 0 ? 1 : 0;

  // Only foreground voxels are visited; outside the grid counts as background (neighbours of
  // voxels on the grid's faces are bounds-checked).
  std::vector<std::int64_t> active;
  for (std::int64_t v = 0; v < std::int64_t(mask.data.size()); ++v)
    if (mask.data[std::size_t(v)] != 0) active.push_back(v);
  const Neighbourhood& nb = neighbourhood();
  std::array<std::int64_t, 26> delta{};
  for (std::size_t b = 0; b < 26; ++b)
    delta[b] = nb.offset[b][0] +
               std::int64_t(n[0]) * (nb.offset[b][1] + std::int64_t(n[1]) * nb.offset[b][2]);

  const auto neighbours = [&](std::int64_t v) {
    const int i = int(v % n[0]), j = int((v / n[0]) % n[1]),
              k = int(v / (std::int64_t(n[0]) * n[1]));
    const bool inside = i > 0 && j > 0 && k > 0 && i < n[0] - 1 && j < n[1] - 1 && k < n[2] - 1;
    std::uint32_t fg = 0;
    for (std::size_t b = 0; b < 26; ++b) {
      if (!inside && !mask.geometry.contains_index(i + nb.offset[b][0], j + nb.offset[b][1],
                                                   k + nb.offset[b][2]))
        continue;
      if (mask.data[std::size_t(v + delta[b])] != 0) fg |= 1u << b;
    }
    return fg;
  };
  // Bits of the six face neighbours in the order +x, −x, +y, −y, +z, −z.
  std::array<std::uint32_t, 6> face_bit{};
  for (std::size_t b = 0; b < 26; ++b) {
    const auto& o = nb.offset[b];
    for (std::size_t d = 0; d < 6; ++d) {
      std::array<int, 3> want{0, 0, 0};
      want[d / 2] = d % 2 == 0 ? 1 : -1;
      if (o == want) face_bit[d] = 1u << b;
    }
  }

  ThinningReport report;
  std::vector<std::int64_t> candidates;
  for (bool changed = true; changed;) {
    changed = false;
    ++report.iterations;
    for (std::size_t d = 0; d < 6; ++d) {
      candidates.clear();
      for (const std::int64_t v : active) {
        const std::uint32_t fg = neighbours(v);
        if ((fg & face_bit[d]) != 0) continue;      // not a border point in direction d
        if (__builtin_popcount(fg) <= 1) continue;  // end point (or isolated): keep
        if (is_simple(fg)) candidates.push_back(v);
      }
      for (const std::int64_t v : candidates) {
        const std::uint32_t fg = neighbours(v);
        if (__builtin_popcount(fg) <= 1 || !is_simple(fg)) continue;
        mask.data[std::size_t(v)] = 0;
        ++report.removed;
        changed = true;
      }
      std::erase_if(active, [&](std::int64_t v) { return mask.data[std::size_t(v)] == 0; });
    }
  }
  report.remaining = std::int64_t(active.size());
  return report;
}

}  // namespace brainshift::imaging
