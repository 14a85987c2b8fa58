// Places a sampling grid around a world-space box. Nodes sit on integer multiples of the
// cell size h (so two grids with the same h share nodes, and the grid can be written as a
// reference-code .sdf file with r = 1/h), with `border_cells` extra nodes on every side.
// Grids that would not fit in memory are refused with the key to change (cell_size).
#pragma once
#include <Eigen/Geometry>

#include "models/geometry/sdf_grid.h"

namespace ssc {

constexpr int kMaxGridNodesPerAxis = 400;
constexpr long kMaxGridNodes = 20'000'000;

// A grid with phi allocated and filled with +infinity. Node index range per axis:
// floor(min/h) - border .. ceil(max/h) + border.
SdfGrid make_grid_for_bounds(const Eigen::AlignedBox3d& world_bounds, double cell_size,
                             int border_cells);

}  // namespace ssc
