// Turns a scene's object description into its rest-pose SDF and simulation grid.
#pragma once
#include "models/geometry/sdf_grid.h"
#include "models/grid/sim_grid.h"
#include "models/sim/scene.h"

namespace ssc {

// Border of empty cells around the object, as in the reference code.
constexpr int kGridBorderCells = 3;

SdfGrid build_rest_sdf(const Scene& scene);
SimGrid build_body_grid(const Scene& scene);

}  // namespace ssc
