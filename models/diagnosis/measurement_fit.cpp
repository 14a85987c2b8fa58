// Fitting a measurement candidate (see measurement_fit.h).
#include "models/diagnosis/measurement_fit.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <tuple>

#include "models/cost/surface_constraint.h"
#include "models/sim/compute_device.h"
#include "models/sim/observation_setup.h"
#include "models/sim/parameters.h"
#include "models/sim/simulation.h"
#include "runtime/errors.h"

namespace ssc {
namespace {

// A correction that removes less than this fraction of the held-in cost is not refitted.
constexpr double kRefitGain = 0.02;
constexpr int kScan = 41, kGolden = 30, kMostRefits = 2;
// Keeping every step's state of a larger body or a longer run would take too much memory.
constexpr double kMostTrackBytes = 2e9;

// The displacement (active nodes) and band displacement of the steps kept (every step for a
// time offset, else the frames' steps; the others stay empty), from the rest state on.
struct MotionTrack {
  std::vector<std::vector<double>> u, band;
};

MotionTrack track_motion(const Problem& p, const PhysicalParameters& params, const std::vector<char>& keep,
                         const std::string& device) {
  const SimGrid& g = p.grid;
  const int last_step = int(keep.size()) - 1;
  const double bytes = 8.0 * 3 * double(g.node_count + g.band_count) * double(std::count(keep.begin(), keep.end(), 1));
  if (bytes > kMostTrackBytes)
    throw SimulationError(fmt::format("keeping {} steps' states would take {:.1f} GB",
                                      std::count(keep.begin(), keep.end(), 1), bytes / 1e9));
  Scene scene = p.scene;
  scene.time.steps = std::max(scene.time.steps, last_step);
  Simulation sim(scene, g, 1, true);
  place_on(sim, device);
  sim.set_parameters(0, params);
  MotionTrack t;
  t.u.resize(keep.size());
  t.band.resize(keep.size());
  const size_t nu = 3 * size_t(g.node_count), nb = 3 * size_t(g.band_count);
  t.u[0].assign(sim.displacement(0), sim.displacement(0) + nu);
  t.band[0].assign(nb, 0.0);
  for (int k = 1; k <= last_step; ++k) {
    sim.step(keep[size_t(k)] != 0, keep[size_t(k)] != 0);  // the band at the kept steps alone
    if (!keep[size_t(k)]) continue;
    t.u[size_t(k)].assign(sim.displacement(0), sim.displacement(0) + nu);
    t.band[size_t(k)].assign(sim.band_displacement(0), sim.band_displacement(0) + nb);
  }
  return t;
}

// A frame's observed points in each camera's frame, as recorded, with the camera's pose: a
// focal-length or depth correction scales them there (measurement_correction.h).
struct CameraPoints {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d eye;
  std::vector<Eigen::Vector3d> local;
};

std::vector<std::vector<CameraPoints>> camera_points(const ObservationSet& set, int frames) {
  std::vector<std::vector<CameraPoints>> out(size_t(std::min(frames, int(set.frames.size()))));
  for (size_t f = 0; f < out.size(); ++f)
    for (size_t i = 0; i < set.cameras.size(); ++i) {
      const DepthCamera& cam = set.cameras[i];
      const DepthImage& image = set.frames[f][i];
      CameraPoints cp{cam.camera_to_world.topLeftCorner<3, 3>(), cam.camera_to_world.topRightCorner<3, 1>(), {}};
      for (int v = 0; v < image.height; ++v)
        for (int u = 0; u < image.width; ++u)
          if (const double z = image.at(u, v); z > 0)
            cp.local.emplace_back((u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z);
      out[f].push_back(std::move(cp));
    }
  return out;
}

// The held-in cost of the observations corrected by `value` against the tracked motion; a
// frame between two steps sees their linear blend.
double held_in_cost(const Problem& p, const std::vector<std::vector<CameraPoints>>& points,
                    const std::string& parameter, double value, const MotionTrack& track,
                    const SurfaceConstraintCost& cost) {
  const MeasurementCorrection m = measurement_correction(parameter, value);
  const Eigen::Vector3d scale(m.depth_scale / m.focal_scale, m.depth_scale / m.focal_scale, m.depth_scale);
  const double dt = p.scene.time.dt;
  std::vector<double> u, band;
  std::vector<Eigen::Vector3d> world;
  double sum = 0;
  for (size_t f = 0; f < points.size(); ++f) {
    const double s = std::clamp(p.frames[f].step + m.time_offset / dt, 0.0, double(track.u.size() - 1));
    const size_t k0 = size_t(std::floor(s));
    const double w = s - double(k0);
    const size_t k1 = w > 0 ? std::min(k0 + 1, track.u.size() - 1) : k0;
    u.resize(track.u[k0].size());
    band.resize(track.band[k0].size());
    for (size_t i = 0; i < u.size(); ++i) u[i] = (1 - w) * track.u[k0][i] + w * track.u[k1][i];
    for (size_t i = 0; i < band.size(); ++i) band[i] = (1 - w) * track.band[k0][i] + w * track.band[k1][i];
    world.clear();
    for (const CameraPoints& cp : points[f])
      for (const Eigen::Vector3d& q : cp.local) world.push_back(cp.rotation * q.cwiseProduct(scale) + cp.eye);
    sum += cost.evaluate(world, p.frames[f].weight, u.data(), band.data(), nullptr, nullptr).cost;
  }
  return sum;
}

// The value in [lo, hi] with the lowest held-in cost: a scan, then golden-section search
// around its best.
double search(const std::function<double(double)>& J, double lo, double hi) {
  double best = lo, best_cost = J(lo);
  for (int i = 1; i < kScan; ++i) {
    const double x = lo + (hi - lo) * i / (kScan - 1), c = J(x);
    if (c < best_cost) best = x, best_cost = c;
  }
  const double step = (hi - lo) / (kScan - 1);
  double a = std::max(lo, best - step), b = std::min(hi, best + step);
  const double r = (std::sqrt(5.0) - 1) / 2;
  double x1 = b - r * (b - a), x2 = a + r * (b - a), c1 = J(x1), c2 = J(x2);
  for (int i = 0; i < kGolden; ++i) {
    if (c1 < c2) b = x2, x2 = x1, c2 = c1, x1 = b - r * (b - a), c1 = J(x1);
    else a = x1, x1 = x2, c1 = c2, x2 = a + r * (b - a), c2 = J(x2);
  }
  const double x = c1 < c2 ? x1 : x2;
  return std::min(c1, c2) < best_cost ? x : best;
}

}  // namespace

MeasurementCorrection measurement_correction(const std::string& parameter, double value) {
  MeasurementCorrection m;
  if (parameter == "camera.focal_scale") m.focal_scale = value;
  else if (parameter == "camera.depth_scale") m.depth_scale = value;
  else if (parameter == "camera.time_offset") m.time_offset = value;
  else throw std::logic_error("measurement_correction: unknown parameter " + parameter);
  return m;
}

void apply_measurement(Problem& p, const MeasurementCorrection& m, const std::string& observation_dir) {
  MeasurementCorrection rounded = m;
  rounded.time_offset = std::round(m.time_offset / p.scene.time.dt) * p.scene.time.dt;
  p.observations = corrected(p.observations, rounded);
  const std::vector<ObservedFrame> before = p.frames;
  p.frames = observed_frames(p.observations, p.scene.time.dt, observation_dir);
  for (size_t f = 0; f < p.frames.size() && f < before.size(); ++f) p.frames[f].weight = before[f].weight;
  for (const ObservedFrame& f : p.frames) p.scene.time.steps = std::max(p.scene.time.steps, f.step);
}

namespace {

// What a correction is searched over: its parameter, its range, the steps whose states the
// search needs, the held-in frames' points and their cost.
struct CorrectionSearch {
  std::string parameter;
  double lo = 0, hi = 0;
  std::vector<char> keep;
  std::vector<std::vector<CameraPoints>> points;
  std::unique_ptr<SurfaceConstraintCost> cost;
};

CorrectionSearch correction_search(const ExtensionRow& row, const Problem& recorded, const DiagnosisContext& c) {
  CorrectionSearch s;
  s.parameter = row.parameters(recorded.scene).at(0);
  const double dt = recorded.scene.time.dt;
  std::tie(s.lo, s.hi) = plausible_range(recorded.scene, s.parameter, c.extent);
  int last_step = 0;
  for (int f = 0; f < c.heldin && f < int(recorded.frames.size()); ++f)
    last_step = std::max(last_step, recorded.frames[size_t(f)].step);
  const bool clock = s.parameter == "camera.time_offset";
  if (clock) {
    // No frame may move before the start; the motion is tracked as far as the latest frame can go.
    s.lo = std::max(s.lo, -recorded.frames.front().step * dt);
    last_step += int(std::ceil(s.hi / dt)) + 1;
  }
  s.keep.assign(size_t(last_step) + 1, clock ? 1 : 0);
  for (int f = 0; f < c.heldin && f < int(recorded.frames.size()); ++f) s.keep[size_t(recorded.frames[size_t(f)].step)] = 1;
  s.cost = std::make_unique<SurfaceConstraintCost>(recorded.grid, recorded.phi_max);
  s.points = camera_points(recorded.observations, c.heldin);
  return s;
}

struct Found {
  double value = 0;          // the correction with the lowest held-in cost
  double before = 0, after = 0;  // the held-in cost at the value searched from, and at `value`
};

// The correction that best lays the held-in frames onto the better of `motions`.
Found search_correction(const CorrectionSearch& s, const Problem& recorded, const std::vector<PhysicalParameters>& motions,
                        double from, const std::string& device) {
  Found found{from, 0, std::numeric_limits<double>::infinity()};
  std::string failure;
  for (const PhysicalParameters& motion : motions) {
    MotionTrack track;
    try {
      track = track_motion(recorded, motion, s.keep, device);
    } catch (const SimulationError& e) {
      failure = e.what();
      continue;
    }
    auto J = [&](double v) { return held_in_cost(recorded, s.points, s.parameter, v, track, *s.cost); };
    const double x = search(J, s.lo, s.hi), cost_x = J(x);
    if (cost_x < found.after) found = {x, J(from), cost_x};
  }
  if (!std::isfinite(found.after)) throw SimulationError("no motion to lay the frames onto: " + failure);
  return found;
}

// `fm` as scored: `model`'s problem with its frames corrected by `value`, their costs at fm's
// parameters, and the correction as its last parameter.
void score_corrected(FittedModel& fm, const Problem& problem, const std::string& parameter, double value,
                     const DiagnosisContext& c) {
  if (parameter == "camera.time_offset") value = std::round(value / problem.scene.time.dt) * problem.scene.time.dt;
  fm.problem = problem;
  apply_measurement(fm.problem, measurement_correction(parameter, value), c.observations);
  PhysicalParameters held = with_values(fm.problem.scene, fm.names, fm.values);
  fm.frame_costs = per_frame_costs(fm.problem, held, c.options.device);
  fm.heldin_cost = fm.heldout_cost = 0;
  for (size_t f = 0; f < fm.frame_costs.size(); ++f)
    (int(f) < c.heldin ? fm.heldin_cost : fm.heldout_cost) += fm.frame_costs[f];
  fm.names.push_back(parameter);
  fm.values.conservativeResize(fm.values.size() + 1);
  fm.values[fm.values.size() - 1] = value;
}

// The correction fitted with `model`'s physics (`physics`: its scene keys): laid onto its
// motion, and where it gains, `model`'s parameters refitted on the corrected frames from
// `starts` and the correction searched again at that fit.
FittedModel fit_correction(const ExtensionRow& row, const FittedModel& model, ModelSpec physics,
                           const DiagnosisContext& c, std::vector<std::map<std::string, double>>& starts) {
  const auto t0 = std::chrono::steady_clock::now();
  const Problem& recorded = model.problem;
  const CorrectionSearch s = correction_search(row, recorded, c);
  FittedModel fm = model;
  fm.name = row.name;
  fm.extra = {s.parameter};
  fm.note.clear();
  fm.proposal.clear();
  double value = row.off_value;
  for (int refit = 0;; ++refit) {
    // The motion the frames are laid onto: the current fit's, and at the first round also the
    // scene's nominal one (a wrong clock or scale can drive the base fit far off, even to a
    // run the energy audit stops); the better of them.
    std::vector<PhysicalParameters> motions = {with_values(recorded.scene, fm.names, fm.values)};
    if (refit == 0) motions.push_back(PhysicalParameters::from_scene(recorded.scene));
    const Found found = search_correction(s, recorded, motions, value, c.options.device);
    const double gain = found.before > 0 ? 1 - found.after / found.before : 0;
    const bool moved = std::abs(found.value - value) > 1e-3 * (s.hi - s.lo);
    value = found.value;
    if (refit == kMostRefits || gain < kRefitGain || (refit > 0 && !moved)) {
      if (refit == 0)
        fm.note = fmt::format("fitted with the {} model's physics: the correction removes {:.1f} % of the held-in "
                              "cost, below the {:.0f} % worth a refit",
                              model.name, 100 * gain, 100 * kRefitGain);
      break;
    }
    ModelSpec spec = physics;
    const MeasurementCorrection m = measurement_correction(s.parameter, value);
    spec.adjust = [m, dir = c.observations](Problem& q) { apply_measurement(q, m, dir); };
    FittedModel refitted = fit_together({spec}, c, starts)[0];
    if (refitted.failed) {
      fm.note = "the refit with the corrected frames failed: " + refitted.failure;
      break;
    }
    fm = std::move(refitted);
    fm.name = row.name;
    fm.extra = {s.parameter};
  }
  score_corrected(fm, model.problem, s.parameter, value, c);
  fm.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return fm;
}

}  // namespace

FittedModel fit_measurement(const ExtensionRow& row, const FittedModel& base, const DiagnosisContext& c,
                            std::vector<std::map<std::string, double>>& base_starts) {
  return fit_correction(row, base, ModelSpec{row.name}, c, base_starts);
}

FittedModel measurement_on(const ExtensionRow& row, const FittedModel& model, const DiagnosisContext& c) {
  ModelSpec physics = model.spec ? *model.spec : ModelSpec{model.name};
  physics.name = row.name + " with " + model.name;
  std::vector<std::map<std::string, double>> start = {values_by_name(model)};
  return fit_correction(row, model, physics, c, start);
}

}  // namespace ssc
