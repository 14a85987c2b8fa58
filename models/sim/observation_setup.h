// The scene's "observation" section (synthetic depth cameras, noise, cost threshold),
// rendering synthetic observations from a simulation, and turning an observation folder
// (synthetic or recorded) into the observed frames of the cost.
#pragma once
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/observation/camera.h"
#include "models/observation/observation_set.h"
#include "models/sim/gradient.h"
#include "models/sim/scene.h"

namespace ssc {

class Simulation;

struct ObservationSpec {
  int every = 1;              // observe every n-th simulation step (frame 0 = rest state)
  double noise = 0;           // metres, std along the viewing ray
  std::uint64_t seed = 42;
  double depth_scale = 1e-4;  // metres per PNG unit
  double phi_max = 0;         // metres, cost threshold; 0: twice the cell size
  std::vector<DepthCamera> cameras;
};

// Parses scene.extra["observation"]; InputError naming the scene and key.
ObservationSpec parse_observation_spec(const Scene& scene);
// The same for an observation section read from anywhere (`key` is its dotted name in
// `file`, "" for a top-level object), e.g. the cameras file of `ssc render`.
ObservationSpec parse_observation_section(const nlohmann::json& section, const std::string& file,
                                          const std::string& key);

// Simulates the scene and renders every camera at every observed step; the set lists the
// frames' times (frame_times) and the noise (depth_noise).
// `configure` may place the simulation on a device before it runs; `finished` sees it
// after the last step (for the run's warnings).
ObservationSet render_observations(const Scene& scene, const SimGrid& grid, const ObservationSpec& spec,
                                   const std::function<void(int, int)>& progress = {},
                                   const std::function<void(Simulation&)>& configure = {},
                                   const std::function<void(const Simulation&)>& finished = {});

// How far (in steps) a frame's own time (cameras.json frame_times) may lie from the
// simulation step it is compared with: timestamps written with a few digits, not jitter.
constexpr double kFrameTimeStepTolerance = 0.01;

// Observed world points per frame, each mapped to the simulation step it shows: the step
// nearest its frame_times entry, or (without frame_times) the step at first_frame_time +
// f * dt, which must be exact. InputError (naming dir, cameras.json and the key) if a time is
// negative or off the steps, two frames share a step, or no frame has a point at all.
std::vector<ObservedFrame> observed_frames(const ObservationSet& set, double sim_dt, const std::string& dir);

}  // namespace ssc
