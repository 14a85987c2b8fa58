// The simulation grid built from a rest-pose SDF, following the paper's rules:
//  - values with |phi| < zero_cutoff * h are set to exactly 0;
//  - a cell is active iff one of its 8 corner values is < 0; all corners of active cells
//    are active nodes (they carry displacement unknowns), numbered in scan order;
//  - band ("extension") nodes are the other grid nodes within an L1 (6-neighbour) graph
//    distance of band_width from an active node; band_width <= 0 means the whole grid;
//  - each active cell stores its 8 cut-cell volume weights (integral of N_c over the
//    body part of the cell) and surface weights;
//  - contact points are the crossings of the rest surface with the edges of active cells and
//    the surface nodes (phi = 0) of active cells, each carrying a share of the cut surface area
//    (the paper takes the crossings alone, so a box on grid planes had none on its rims); where
//    the shape's exact distance is given, its crossings with a finer lattice in each active cell
//    instead, so that a box off the grid planes has points out to its rims. A point moves with
//    its cell's trilinear interpolation.
// Node<->cell and node<->point incidence lists (fixed order) turn every element-to-node
// sum into a deterministic gather.
#pragma once
#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "models/geometry/sdf_grid.h"
#include "runtime/static_arrays.h"

namespace ssc {

struct GridOptions {
  double zero_cutoff = 0.01;           // in cell sizes
  int band_width = 0;                  // in grid steps; <= 0: whole grid
  int integration_subdivisions = 4;    // per axis, for cut cells
  double min_node_volume = 0.05;       // floor on every corner weight, in units of h^3/8
  int contact_subdivisions = 2;        // per axis, for contact points on an exact surface
};

// The rest body's exact signed distance at a world point (m, negative inside), where the shape
// has one; empty: the grid's trilinear SDF.
using RestSurface = std::function<double(const Eigen::Vector3d&)>;

// Where the rest body starts: the grid is laid in the object's own frame (scene grid.frame
// "object": its origin and axes), and the object's position and rotation are the body's
// initial pose, a rigid initial displacement R X + t - X. Rest positions X (node_rest,
// cell_center, the SDF) are in that frame; what the scene gives in the world at the start
// (material regions, the stiffness gradient, dirichlet boxes, probe points) is mapped by
// start / rest.
struct RestPose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d start(const Eigen::Vector3d& rest) const { return rotation * rest + translation; }
  Eigen::Vector3d rest(const Eigen::Vector3d& start) const { return rotation.transpose() * (start - translation); }
};

// The model's grid: the engine's arrays (runtime/static_arrays.h) and what the model keeps
// beside them (the SDF, the scan-order maps, surface weights, volumes).
struct SimGrid : StaticArrays {
  SdfGrid sdf;  // rest SDF after the zero cutoff

  std::vector<long> cell_origin;              // flat SDF index of corner 0, per cell
  std::vector<double> cell_volume;            // per cell, m^3
  std::vector<double> cell_area;              // per cell, m^2
  std::vector<double> cell_center;            // 3 per cell: rest centroid of its inside part, m
  std::vector<int> cell_at_origin;            // per SDF node: id of the cell whose corner 0 it is, or -1

  std::vector<long> node_grid;                // flat SDF index per active node
  int floored_weights = 0;                    // corner weights raised to the floor

  std::vector<long> band_grid;                // flat SDF index per band node
  std::vector<int> grid_kind;                 // per SDF node: active id >= 0, -(band id) - 2, or -1

  double total_volume = 0;                    // m^3, the body's cut volume (no floor)
  Eigen::Vector3d rest_center_of_mass = Eigen::Vector3d::Zero();
  RestPose pose;                              // the body's initial pose (identity: the rest pose)

  // A rest point's position at the start, in the world.
  Eigen::Vector3d start(const Eigen::Vector3d& rest) const { return pose.start(rest); }
  Eigen::Vector3d node_start(int node) const {
    return pose.start(Eigen::Vector3d(node_rest[3 * size_t(node)], node_rest[3 * size_t(node) + 1], node_rest[3 * size_t(node) + 2]));
  }
  Eigen::Vector3d cell_start(int cell) const {
    return pose.start(Eigen::Vector3d(cell_center[3 * size_t(cell)], cell_center[3 * size_t(cell) + 1], cell_center[3 * size_t(cell) + 2]));
  }
  Eigen::Vector3d start_center_of_mass() const { return pose.start(rest_center_of_mass); }
  Eigen::Vector3d point_start(const ContactPoint& p) const {
    return pose.start(Eigen::Vector3d(p.at(node_rest, 0), p.at(node_rest, 1), p.at(node_rest, 2)));
  }

  static int band_ref_of_active(int active) { return -active - 2; }
};

// Builds the grid; throws InputError (naming `source`) if nothing is inside.
SimGrid build_sim_grid(SdfGrid sdf, const GridOptions& options, const std::string& source,
                       const RestSurface& exact = {});

// Cell containing a rest-pose point and its local coordinates in [0,1]^3, or -1.
int find_cell(const SimGrid& grid, const Eigen::Vector3d& rest_point, Eigen::Vector3d* local);

// The largest extent of the rest body's nodes along an axis (m); 1 for an empty grid.
double rest_extent(const SimGrid& grid);

}  // namespace ssc
