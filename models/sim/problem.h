// An inverse problem as the commands load it: the scene (what is known), its grid, the
// observation folder mapped onto simulation steps, and the cost threshold phi_max.
#pragma once
#include <string>
#include <vector>

#include "models/grid/sim_grid.h"
#include "models/observation/observation_set.h"
#include "models/sim/gradient.h"
#include "models/sim/scene.h"

namespace ssc {

struct Problem {
  Scene scene;
  SimGrid grid;
  ObservationSet observations;
  std::vector<ObservedFrame> frames;
  double phi_max = 0;  // metres
};

// The observed points are checked against the scene's ground planes (models/sim/plane_points.h:
// a table left in the depth is a warning or an InputError).
// phi_max: the override if > 0, else the scene's observation.phi_max, else 2 cell sizes (a
// negative override is an error). The scene's time.steps is raised if the observations reach
// further (a note says so); frames before t = 0 are left out (a warning says so). `parameters` are the
// ones the command fits, sweeps or differentiates: the scene models every effect they belong
// to (a friction coefficient turns friction on, at the scene's coefficient, 0 by default).
Problem load_problem(const std::string& scene_path, const std::vector<std::string>& overrides,
                     const std::string& observation_dir, double phi_max_override = 0,
                     const std::vector<std::string>& parameters = {});

}  // namespace ssc
