// Goodness of fit (see goodness_of_fit.h).
#include "models/diagnosis/goodness_of_fit.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "models/io/run_record.h"
#include "models/observation/camera.h"

namespace ssc {
namespace {

// Pixels seen at more than about 75 degrees from the surface normal are left out of the
// noise estimate: there a model error is hardly damped by the neighbour difference.
constexpr double kMinEstimateCosine = 0.25;

// Where a matched point's residual noise comes from: its depth z and the factors |r . n| by
// which a depth error moves the residual (r scaled to unit z depth, and to unit length).
struct PointGeometry {
  bool known = false;
  double z = 0, c_depth = 0, c_ray = 0;
};

std::vector<PointGeometry> point_geometry(const Problem& problem, const Residuals& r) {
  const ObservationSet& obs = problem.observations;
  std::vector<PointGeometry> out(r.points.size());
  for (size_t i = 0; i < r.points.size(); ++i) {
    const ResidualPoint& p = r.points[i];
    if (!p.matched || p.pixel < 0 || size_t(p.frame) >= obs.frames.size() || size_t(p.camera) >= obs.cameras.size())
      continue;
    const DepthImage& image = obs.frames[size_t(p.frame)][size_t(p.camera)];
    if (p.pixel >= image.width * image.height || !(image.depth[size_t(p.pixel)] > 0)) continue;
    const DepthCamera& cam = obs.cameras[size_t(p.camera)];
    const Eigen::Vector3d ray = ray_direction_world(cam, p.pixel % image.width, p.pixel / image.width);
    const double axial = ray.dot(cam.camera_to_world.block<3, 1>(0, 2));  // 1 / length of the unit-depth ray
    out[i] = {true, image.depth[size_t(p.pixel)], std::abs(ray.dot(p.normal)) / axial, std::abs(ray.dot(p.normal))};
  }
  return out;
}

double median(std::vector<double> v) {
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + long(m), v.end());
  const double upper = v[m];
  if (v.size() % 2) return upper;
  return 0.5 * (upper + *std::max_element(v.begin(), v.begin() + long(m)));
}

// sigma of the z depth from the residual differences of neighbouring pixels (see the header);
// NaN with fewer than kFitMinMatchedPoints pairs.
double estimate_depth_sigma(const Problem& problem, const Residuals& r, const std::vector<PointGeometry>& geo,
                            int* pairs) {
  const ObservationSet& obs = problem.observations;
  auto usable = [&](size_t k) { return geo[k].known && geo[k].c_ray >= kMinEstimateCosine; };
  std::vector<double> d;
  std::vector<long> at;
  for (size_t begin = 0, end; begin < r.points.size(); begin = end) {  // one frame and camera at a time
    const ResidualPoint& first = r.points[begin];
    for (end = begin;
         end < r.points.size() && r.points[end].frame == first.frame && r.points[end].camera == first.camera;)
      ++end;
    if (first.pixel < 0 || size_t(first.frame) >= obs.frames.size() || size_t(first.camera) >= obs.cameras.size())
      continue;
    const DepthImage& image = obs.frames[size_t(first.frame)][size_t(first.camera)];
    at.assign(size_t(image.width) * size_t(image.height), -1);
    for (size_t k = begin; k < end; ++k)
      if (r.points[k].pixel >= 0 && r.points[k].pixel < long(at.size())) at[size_t(r.points[k].pixel)] = long(k);
    for (size_t k = begin; k < end; ++k) {
      if (!usable(k)) continue;
      const int pixel = r.points[k].pixel, u = pixel % image.width, v = pixel / image.width;
      for (const long j : {u + 1 < image.width ? at[size_t(pixel + 1)] : -1L,
                           v + 1 < image.height ? at[size_t(pixel + image.width)] : -1L}) {
        if (j < 0 || !usable(size_t(j))) continue;
        const double c2 = geo[k].c_depth * geo[k].c_depth + geo[size_t(j)].c_depth * geo[size_t(j)].c_depth;
        d.push_back((r.points[k].residual - r.points[size_t(j)].residual) / std::sqrt(c2));
      }
    }
  }
  *pairs = int(d.size());
  if (d.size() < size_t(kFitMinMatchedPoints)) return std::numeric_limits<double>::quiet_NaN();
  const double centre = median(d);
  for (double& x : d) x = std::abs(x - centre);
  return 1.4826 * median(d);  // the MAD of a Gaussian is 0.6745 sigma
}

bool every_camera_has_a_model(const ObservationSet& obs) {
  for (size_t c = 0; c < obs.cameras.size(); ++c)
    if (!camera_depth_noise(obs, int(c))) return false;
  return !obs.cameras.empty();
}

struct NoiseSum {
  double var = 0;
  int n = 0;
  void add(double v) { var += v, ++n; }
};

FitGroup make_group(const std::string& kind, const std::string& name, int points, int matched, double rms,
                    const NoiseSum& noise) {
  FitGroup g{kind, name, points, matched, rms, 0.0, std::numeric_limits<double>::quiet_NaN()};
  if (noise.n > 0) g.noise_m = std::sqrt(noise.var / noise.n);
  if (g.noise_m > 0) g.ratio = rms / g.noise_m;
  return g;
}

FitGroup group_from_summary(const std::string& kind, const std::string& name, const nlohmann::json& s,
                            const NoiseSum& noise) {
  return make_group(kind, name, s["points"].get<int>(), s["matched"].get<int>(), s["rms_m"].get<double>(), noise);
}

// "frame 12", "phase contact with plane 0", "region +x-y+z", "normal direction".
std::string group_label(const FitGroup& f) {
  if (f.kind == "frame") return f.name;
  if (f.kind == "direction") return f.name + " direction";
  return f.kind + " " + f.name;
}

std::string list_names(const std::vector<FitGroup>& groups) {
  std::string s;
  const size_t shown = std::min<size_t>(groups.size(), 4);
  for (size_t i = 0; i < shown; ++i)
    s += fmt::format("{}{} ({:.1f} times)",
                     i == 0                                     ? ""
                     : i + 1 == shown && shown == groups.size() ? " and "
                                                                : ", ",
                     group_label(groups[i]), groups[i].ratio);
  if (groups.size() > shown) s += fmt::format(" and {} more", groups.size() - shown);
  return s;
}

std::string noise_description(const GoodnessOfFit& g) {
  if (g.noise_source == "cameras.json") return "from cameras.json's depth_noise";
  return fmt::format("estimated from the residuals of neighbouring pixels: depth sigma {:.3g} mm",
                     1e3 * g.estimated_sigma_m);
}

void judge(GoodnessOfFit& g) {
  const FitGroup& all = g.overall;
  if (g.noise_source == "unknown") return;  // the verdict says why
  if (all.matched < kFitMinMatchedPoints) {
    g.verdict = "too few matched points";
    return;
  }
  auto stands_out = [&](const FitGroup& f) {
    return f.matched >= kFitMinMatchedPoints && f.ratio > kAboveNoiseRatio && f.ratio > kAboveNoiseRatio * all.ratio;
  };
  for (const FitGroup& f : g.frames)
    if (stands_out(f)) g.above.push_back(f);
  for (const FitGroup& f : g.groups)
    if (stands_out(f)) g.above.push_back(f);
  std::stable_sort(g.above.begin(), g.above.end(),
                   [](const FitGroup& a, const FitGroup& b) { return a.ratio > b.ratio; });
  // Above the noise overall, or in a part of the data only (a missed effect may show in a few frames).
  const bool overall = all.ratio > kAboveNoiseRatio;
  g.above_noise = overall || !g.above.empty();
  if (!g.above_noise) {
    g.verdict =
        all.ratio < 1 / kAboveNoiseRatio ? fmt::format("below the noise ({:.2f} times)", all.ratio) : "at the noise";
    return;
  }
  g.verdict = overall ? fmt::format("above the noise ({:.1f} times)", all.ratio)
                      : fmt::format("above the noise in {} ({:.1f} times)", group_label(g.above[0]), g.above[0].ratio);
  const std::string measured =
      fmt::format("RMS {:.3g} mm over {} matched points against {:.3g} mm, {}; above {} counts as a misfit",
                  1e3 * all.rms_m, all.matched, 1e3 * all.noise_m, noise_description(g), kAboveNoiseRatio);
  g.warning = fmt::format(
      "{}: the model leaves structure the noise does not explain{}{}. Likely causes: the cameras' intrinsics (fx, fy, "
      "cx, cy) or depth_scale in cameras.json, segmentation (observed points that are not on the body), or a physical "
      "effect the scene does not model (run `ssc diagnose`). The fitted values may be biased",
      overall ? fmt::format("the fit's residual is {:.1f} times the depth noise ({})", all.ratio, measured)
              : fmt::format("the fit's residual is at the depth noise overall ({:.2f} times; {}) but not everywhere",
                            all.ratio, measured),
      g.above.empty() ? "" : ", most in ", list_names(g.above));
}

}  // namespace

GoodnessOfFit goodness_of_fit(const Problem& problem, const PhysicalParameters& params, const std::string& device) {
  return goodness_of_fit(problem, compute_residuals(problem, params, device));
}

GoodnessOfFit goodness_of_fit(const Problem& problem, const Residuals& r) {
  const ObservationSet& obs = problem.observations;
  GoodnessOfFit g;
  g.quantisation_m = obs.depth_scale / std::sqrt(12.0);
  const std::vector<PointGeometry> geo = point_geometry(problem, r);
  bool placed = true;
  for (size_t i = 0; i < r.points.size(); ++i) placed &= !r.points[i].matched || geo[i].known;
  const bool model = every_camera_has_a_model(obs);
  g.noise_source = !placed ? "unknown" : model ? "cameras.json" : "estimate";
  if (!placed) g.verdict = "noise unknown (the observed points have no pixels to take their depth from)";
  if (g.noise_source == "estimate") {
    g.estimated_sigma_m = estimate_depth_sigma(problem, r, geo, &g.estimate_pairs);
    if (std::isnan(g.estimated_sigma_m)) {
      g.noise_source = "unknown";
      g.verdict = fmt::format(
          "noise unknown (cameras.json gives no depth_noise, and {} pairs of matched neighbouring "
          "pixels are too few to estimate it)",
          g.estimate_pairs);
    } else {
      g.estimated_sigma_m = std::max(g.estimated_sigma_m, g.quantisation_m);
    }
  }

  // Each matched point's residual variance, summed by frame, phase, region and direction.
  std::vector<NoiseSum> by_frame(r.frames.size());
  std::map<std::string, NoiseSum> by_phase, by_region;
  NoiseSum all, normal, tangential;
  const double q2 = g.quantisation_m * g.quantisation_m;
  for (size_t i = 0; i < r.points.size() && g.noise_source != "unknown"; ++i) {
    const ResidualPoint& p = r.points[i];
    if (!p.matched) continue;
    const PointGeometry& pg = geo[i];
    double var = 0;
    if (const DepthNoise* n = model ? camera_depth_noise(obs, p.camera) : nullptr) {
      const double c = n->along_ray ? pg.c_ray : pg.c_depth, s = n->sigma(pg.z);
      var = s * s * c * c + q2 * pg.c_depth * pg.c_depth;
    } else {
      var = g.estimated_sigma_m * g.estimated_sigma_m * pg.c_depth * pg.c_depth;
    }
    all.add(var);
    by_frame[size_t(p.frame)].add(var);
    by_phase[phase_name(r.frames[size_t(p.frame)])].add(var);
    by_region[region_name(p.region)].add(var);
    // The residual's split along the contact plane's normal and across it splits its noise alike.
    const double along = p.residual != 0 ? p.normal_part * p.normal_part / (p.residual * p.residual) : 0.5;
    normal.var += along * var, tangential.var += (1 - along) * var;
    ++normal.n, ++tangential.n;
  }

  const nlohmann::json summary = residual_summary(r);
  g.overall = group_from_summary("all", "all", summary["all"], all);
  for (size_t f = 0; f < r.frames.size(); ++f) {
    const FrameResiduals& fr = r.frames[f];
    g.frames.push_back(
        make_group("frame", fmt::format("frame {}", fr.frame), fr.points, fr.matched, fr.rms, by_frame[f]));
    g.frame_times_s.push_back(fr.time);
  }
  for (const auto& [name, s] : summary["by_phase"].items())
    g.groups.push_back(group_from_summary("phase", name, s, by_phase[name]));
  for (const auto& [name, s] : summary["by_region"].items())
    g.groups.push_back(group_from_summary("region", name, s, by_region[name]));
  const nlohmann::json& dir = summary["by_direction"];
  g.groups.push_back(
      make_group("direction", "normal", g.overall.points, g.overall.matched, dir["normal_rms_m"], normal));
  g.groups.push_back(
      make_group("direction", "tangential", g.overall.points, g.overall.matched, dir["tangential_rms_m"], tangential));
  judge(g);
  return g;
}

namespace {

nlohmann::json number_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

nlohmann::json group_json(const FitGroup& f) {
  return {{"points", f.points},
          {"matched", f.matched},
          {"matched_fraction", f.points ? double(f.matched) / f.points : 0.0},
          {"rms_m", f.rms_m},
          {"noise_m", f.noise_m > 0 ? nlohmann::json(f.noise_m) : nlohmann::json(nullptr)},
          {"ratio", number_or_null(f.ratio)}};
}

}  // namespace

nlohmann::json goodness_json(const GoodnessOfFit& g) {
  nlohmann::json j = group_json(g.overall);
  j["verdict"] = g.verdict;
  j["above_noise"] = g.above_noise;
  j["threshold_ratio"] = kAboveNoiseRatio;
  j["min_matched_points"] = kFitMinMatchedPoints;
  nlohmann::json noise = {{"source", g.noise_source}, {"quantisation_m", g.quantisation_m}};
  if (g.noise_source == "estimate" || g.estimate_pairs > 0) {
    noise["estimated_depth_sigma_m"] = number_or_null(g.estimated_sigma_m);
    noise["neighbour_pairs"] = g.estimate_pairs;
    noise["method"] =
        "1.4826 x the median absolute deviation of the residual differences of neighbouring pixels, floored at the "
        "depth quantisation; an estimate that assumes independent noise per pixel";
  }
  j["noise"] = noise;
  nlohmann::json frames = nlohmann::json::array();
  for (size_t f = 0; f < g.frames.size(); ++f) {
    nlohmann::json e = group_json(g.frames[f]);
    e["frame"] = int(f);
    e["time_s"] = g.frame_times_s[f];
    frames.push_back(e);
  }
  j["by_frame"] = frames;
  for (const char* kind : {"phase", "region", "direction"}) {
    nlohmann::json k = nlohmann::json::object();
    for (const FitGroup& f : g.groups)
      if (f.kind == kind) k[f.name] = group_json(f);
    j[std::string("by_") + kind] = k;
  }
  nlohmann::json above = nlohmann::json::array();
  for (const FitGroup& f : g.above) {
    nlohmann::json e = group_json(f);
    e["kind"] = f.kind;
    e["name"] = f.name;
    above.push_back(e);
  }
  j["above_noise_in"] = above;
  if (!g.warning.empty()) j["warning"] = g.warning;
  return j;
}

std::string goodness_line(const GoodnessOfFit& g) {
  const FitGroup& a = g.overall;
  std::string s = fmt::format("goodness of fit: RMS residual {:.3g} mm over {} of {} points ({:.1f} %)", 1e3 * a.rms_m,
                              a.matched, a.points, a.points ? 100.0 * a.matched / a.points : 0.0);
  if (g.noise_source == "unknown") return s + ": " + g.verdict;
  s += fmt::format(" against noise {:.3g} mm ({}): ratio {:.2f}, {}", 1e3 * a.noise_m,
                   g.noise_source == "cameras.json" ? "cameras.json" : "estimated", a.ratio, g.verdict);
  return s;
}

void warn_if_above_noise(const GoodnessOfFit& g) {
  if (g.above_noise) warn("fit_above_noise", g.warning);
}

}  // namespace ssc
