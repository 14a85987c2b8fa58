#include "models/geometry/grid_placement.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "runtime/errors.h"

namespace ssc {

namespace {

// Nodes per axis as doubles, so that a tiny cell size cannot overflow an int.
Eigen::Vector3d node_counts(const Eigen::AlignedBox3d& box, double h, int border) {
  Eigen::Vector3d n;
  for (int a = 0; a < 3; ++a)
    n[a] = std::ceil(box.max()[a] / h) - std::floor(box.min()[a] / h) + 2.0 * border + 1.0;
  return n;
}

bool fits(const Eigen::Vector3d& n) {
  return n.maxCoeff() <= kMaxGridNodesPerAxis && n.prod() <= double(kMaxGridNodes);
}

double smallest_fitting_cell_size(const Eigen::AlignedBox3d& box, double h, int border) {
  double candidate = h;
  while (!fits(node_counts(box, candidate, border))) candidate *= 1.05;
  return candidate;
}

void check_arguments(const Eigen::AlignedBox3d& box, double h, int border) {
  if (!(h > 0) || !std::isfinite(h))
    throw InputError(fmt::format("cell_size must be a positive number of metres, got {}", h));
  if (border < 0) throw InputError(fmt::format("border_cells must be >= 0, got {}", border));
  if (box.isEmpty() || !box.min().allFinite() || !box.max().allFinite())
    throw InputError(
        "cannot place a grid around an empty or non-finite bounding box; check that the "
        "shape has vertices (or a non-zero size) and finite coordinates");
}

}  // namespace

SdfGrid make_grid_for_bounds(const Eigen::AlignedBox3d& world_bounds, double cell_size,
                             int border_cells) {
  check_arguments(world_bounds, cell_size, border_cells);
  const Eigen::Vector3d n = node_counts(world_bounds, cell_size, border_cells);
  if (!fits(n)) {
    throw InputError(fmt::format(
        "a grid with cell_size {} m around the shape's bounds ({:.4g} x {:.4g} x {:.4g} m) "
        "needs {:.3g} x {:.3g} x {:.3g} = {:.3g} million nodes; the limit is {} per axis and "
        "{} million in all. Raise grid.cell_size to at least {:.4g} (or lower grid.resolution)",
        cell_size, world_bounds.sizes().x(), world_bounds.sizes().y(), world_bounds.sizes().z(),
        n.x(), n.y(), n.z(), n.prod() / 1e6, kMaxGridNodesPerAxis, kMaxGridNodes / 1'000'000,
        smallest_fitting_cell_size(world_bounds, cell_size, border_cells)));
  }
  SdfGrid grid;
  grid.cell_size = cell_size;
  grid.size = n.cast<int>();
  for (int a = 0; a < 3; ++a)
    grid.origin[a] = cell_size * (std::floor(world_bounds.min()[a] / cell_size) - border_cells);
  grid.phi.assign(grid.node_count(), std::numeric_limits<double>::infinity());
  return grid;
}

}  // namespace ssc
