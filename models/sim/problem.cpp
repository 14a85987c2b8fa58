// Loading of inverse problems (see problem.h).
#include "models/sim/problem.h"

#include <fmt/format.h>

#include <cmath>

#include "models/io/notes.h"
#include "models/io/run_record.h"
#include "models/sim/body.h"
#include "models/sim/extensions.h"
#include "models/sim/observation_setup.h"
#include "models/sim/plane_points.h"
#include "runtime/errors.h"

namespace ssc {
namespace {

// Frames before t = 0 (a negative first_frame_time) show the body before the simulation
// starts: nothing to compare them with. They are left out of the frames and the observation
// set alike (frame f of one is frame f of the other), with a warning; none left is an error.
void drop_frames_before_start(Problem& p, const std::string& dir) {
  size_t early = 0;
  while (early < p.frames.size() && p.frames[early].step < 0) ++early;
  if (early == 0) return;
  ObservationSet& o = p.observations;
  const double last = frame_time(o, int(early - 1));
  if (early == p.frames.size())
    throw InputError(fmt::format("{}: every observed frame is before t = 0 (first_frame_time = {} s, the last frame at "
                                 "t = {:.4g} s), where the simulation starts; set first_frame_time in cameras.json to "
                                 "the time of frame 0 in the scene's clock",
                                 dir, o.first_frame_time, last));
  warn("frames_before_start",
       fmt::format("{}: the first {} observed frame(s) (t = {:.4g} .. {:.4g} s) are before t = 0, where the simulation "
                   "starts, and are left out; the frames are counted from the next one. If the body was already moving "
                   "then, set first_frame_time in cameras.json to the time of frame 0 in the scene's clock",
                   dir, early, o.first_frame_time, last));
  p.frames.erase(p.frames.begin(), p.frames.begin() + long(early));
  o.frames.erase(o.frames.begin(), o.frames.begin() + long(std::min(early, o.frames.size())));
  o.first_frame_time += double(early) * o.dt;
  o.frame_count -= int(early);
}

}  // namespace

Problem load_problem(const std::string& scene_path, const std::vector<std::string>& overrides,
                     const std::string& observation_dir, double phi_max_override,
                     const std::vector<std::string>& parameters) {
  if (!(phi_max_override >= 0) || !std::isfinite(phi_max_override))
    throw InputError(fmt::format("--phi-max {}: the cost threshold must be a positive distance in metres (leave it out "
                                 "for the scene's observation.phi_max, else 2 cell sizes)",
                                 phi_max_override));
  Problem p;
  p.scene = load_scene(scene_path, overrides);
  model_fitted_extensions(p.scene, parameters);
  p.grid = build_body_grid(p.scene);
  p.observations = read_observations(observation_dir);
  p.frames = observed_frames(p.observations, p.scene.time.dt, observation_dir);
  drop_frames_before_start(p, observation_dir);
  check_table_points(p.frames, p.scene.planes, p.observations, observation_dir);
  const int steps = p.scene.time.steps;
  for (const ObservedFrame& f : p.frames) p.scene.time.steps = std::max(p.scene.time.steps, f.step);
  if (p.scene.time.steps > steps)
    note_once(fmt::format("{}: time.steps raised from {} to {} so that the simulation reaches the last observed frame "
                          "(t = {:.4g} s) of {}",
                          p.scene.file, steps, p.scene.time.steps, p.scene.time.steps * p.scene.time.dt, observation_dir));
  p.phi_max = phi_max_override;
  if (p.phi_max <= 0 && p.scene.extra.contains("observation")) p.phi_max = parse_observation_spec(p.scene).phi_max;
  if (p.phi_max <= 0) p.phi_max = 2 * p.grid.h;
  return p;
}

}  // namespace ssc
