// Loading of inverse problems (see problem.h).
#include "models/sim/problem.h"

#include "models/sim/body.h"
#include "models/sim/extensions.h"
#include "models/sim/observation_setup.h"
#include "models/sim/plane_points.h"

namespace ssc {

Problem load_problem(const std::string& scene_path, const std::vector<std::string>& overrides,
                     const std::string& observation_dir, double phi_max_override,
                     const std::vector<std::string>& parameters) {
  Problem p;
  p.scene = load_scene(scene_path, overrides);
  model_fitted_extensions(p.scene, parameters);
  p.grid = build_body_grid(p.scene);
  p.observations = read_observations(observation_dir);
  p.frames = observed_frames(p.observations, p.scene.time.dt, observation_dir);
  check_table_points(p.frames, p.scene.planes, p.observations, observation_dir);
  for (const ObservedFrame& f : p.frames) p.scene.time.steps = std::max(p.scene.time.steps, f.step);
  p.phi_max = phi_max_override;
  if (p.phi_max <= 0 && p.scene.extra.contains("observation")) p.phi_max = parse_observation_spec(p.scene).phi_max;
  if (p.phi_max <= 0) p.phi_max = 2 * p.grid.h;
  return p;
}

}  // namespace ssc
