#pragma once
/// @file
/// @brief The one spatial index of the project: a uniform grid over axis-aligned boxes (the
/// bounding boxes of tetrahedra, triangles, segments, or points as empty boxes), in mm, in
/// whatever frame the caller's coordinates are (world RAS everywhere in brainshift).
///
/// Why a grid and not CGAL's AABB tree: `core/` builds with Eigen + CHOLMOD alone (STYLE.md §1.4:
/// CGAL stays in the meshing target `imaging_cgal`), and the registration's queries (vessel points
/// to skeleton segments, points to tetrahedra, surface to surface) run on items of nearly uniform
/// size, where a grid with cells about one item across answers in O(1) candidates.
///
/// Cell-size heuristic (the only one): the cell is the mean over the items of the longest side of
/// their box (≈ the mean edge length of a mesh), grown when needed so that the grid has at most
/// 8·#items + 1 cells (a bounded memory for very flat or very sparse inputs, and the size for
/// points, whose boxes have no extent). With every box at one point the grid is one cell.

#include "core/config.hpp"

#include <optional>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

namespace brainshift::core {

/// The nearest item of a GridIndex::nearest query and its distance (mm).
struct GridNearest {
  index_t item = -1;
  double distance = 0.0;
};

/// @brief Uniform grid over #I axis-aligned boxes; each item is listed in every cell its box
/// overlaps (CSR storage). Immutable after construction; const queries are thread-safe.
class GridIndex {
 public:
  /// A non-owning reference to a callable `double(index_t item)`: the caller's exact distance (mm)
  /// from the query point to an item. It must be ≥ the distance to the item's box (true for any
  /// item that lies inside its box), or pruning may miss the nearest item.
  class DistanceRef {
   public:
    template <typename F>
    requires(!std::is_same_v<std::remove_cvref_t<F>, DistanceRef>)
        DistanceRef(F&& f)  // NOLINT(google-explicit-constructor): binds a lambda at the call
        : m_object(const_cast<void*>(static_cast<const void*>(&f))),
          m_call([](void* o, index_t i) -> double {
            return (*static_cast<std::remove_reference_t<F>*>(o))(i);
          }) {}
    double operator()(index_t item) const { return m_call(m_object, item); }

   private:
    void* m_object;  // not owned; the callable outlives the query it is passed to
    double (*m_call)(void*, index_t);
  };

  /// An empty index: every query finds nothing.
  GridIndex() = default;

  /// @brief Indexes #I boxes.
  /// @param[in] box_lo #I×3 lower corners (mm).
  /// @param[in] box_hi #I×3 upper corners (mm), ≥ box_lo componentwise.
  /// \throws brainshift::Error on a non-finite corner, box_hi < box_lo or differing row counts.
  GridIndex(ConstRef<MatrixX3d> box_lo, ConstRef<MatrixX3d> box_hi);

  /// @brief Indexes #P points (boxes with no extent).
  /// @param[in] points #P×3 (mm). \throws brainshift::Error on a non-finite coordinate.
  static GridIndex of_points(ConstRef<MatrixX3d> points);

  /// Number of items.
  [[nodiscard]] index_t size() const { return static_cast<index_t>(m_lo.rows()); }
  /// Cell edge length (mm).
  [[nodiscard]] double cell_size() const { return m_cell; }
  /// Number of cells along x, y, z.
  [[nodiscard]] Eigen::Vector3i dims() const { return m_dims; }

  /// @brief The items listed in the cell that contains p: a superset of the items whose box
  /// contains p, ascending. Empty when p lies outside the grid or is not finite.
  [[nodiscard]] std::span<const index_t> cell_items(const Vector3d& p) const;

  /// @brief Every item whose box lies within `radius` of p (Euclidean distance from p to the
  /// box ≤ radius, mm), ascending and without repeats. Empty for a NaN or negative radius or a
  /// non-finite p; an infinite radius returns every item.
  [[nodiscard]] std::vector<index_t> items_within(const Vector3d& p, double radius) const;

  /// @brief The item nearest to p by the caller's exact `distance`, among those within
  /// `max_distance` (mm, inclusive); std::nullopt when there is none, when p is not finite or
  /// when max_distance is NaN or negative. Ties go to the lowest item index, so the answer does
  /// not depend on the cell size. Searches cells in shells of growing Chebyshev radius around p
  /// and stops once every unsearched cell is farther than the best distance found.
  [[nodiscard]] std::optional<GridNearest> nearest(const Vector3d& p, double max_distance,
                                                   DistanceRef distance) const;

  /// Squared Euclidean distance (mm²) from p to the box of `item`.
  [[nodiscard]] double box_squared_distance(index_t item, const Vector3d& p) const;

 private:
  /// Cell of each coordinate of x, clamped into the grid.
  [[nodiscard]] Eigen::Vector3i clamped_cell(const Vector3d& x) const;
  [[nodiscard]] std::size_t cell_index(int i, int j, int k) const;

  MatrixX3d m_lo;
  MatrixX3d m_hi;
  Vector3d m_origin = Vector3d::Zero();
  double m_cell = 1.0;
  Eigen::Vector3i m_dims = Eigen::Vector3i::Ones();
  std::vector<index_t> m_cell_start = {0,
                                       0};  // CSR over cells: items of c in [start[c], start[c+1])
  std::vector<index_t> m_cell_items;
};

}  // namespace brainshift::core
