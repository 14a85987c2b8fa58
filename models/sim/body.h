// Turns a scene's object description into its rest-pose SDF and simulation grid.
#pragma once
#include "models/geometry/sdf_grid.h"
#include "models/grid/sim_grid.h"
#include "models/sim/scene.h"

namespace ssc {

// Border of empty cells around the object, as in the reference code.
constexpr int kGridBorderCells = 3;

// The grid's volume is checked against the object's own (analytic for primitives, enclosed
// for closed meshes; .sdf files have no other volume): more than kVolumeLossWarning off is a
// warning, more than kVolumeLossError lost an InputError.
constexpr double kVolumeLossWarning = 0.05, kVolumeLossError = 0.5;
// A mesh body at least this many metres across is likely in millimetres: a warning.
constexpr double kMillimetreMeshExtent = 10.0;

// The body's initial pose (sim_grid.h): the object's rotation and position when the grid is in
// the object's frame, else the identity.
RestPose initial_pose(const Scene& scene);
// The rest SDF in the grid's frame.
SdfGrid build_rest_sdf(const Scene& scene);
SimGrid build_body_grid(const Scene& scene);
// Each cell's shares of the material regions (StaticArrays::cell_region_share): the fraction of
// kRegionSamples^3 points spread over the cell, inside the body by the rest SDF, whose last
// containing region is each one; warns about regions that hold no part of any cell.
constexpr int kRegionSamples = 4;
void assign_material_regions(const Scene& scene, SimGrid& grid);
double primitive_volume(const Primitive& p);

}  // namespace ssc
