// Residuals of a simulation against its observations (see residuals.h).
#include "models/diagnosis/residuals.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "models/cost/surface_constraint.h"
#include "models/sim/compute_device.h"
#include "models/sim/simulation.h"

namespace ssc {
namespace {

// Signed distance of the body's lowest active node to each plane (metres).
std::vector<double> plane_clearances(const SimGrid& grid, const PhysicalParameters& p, const double* u) {
  std::vector<double> out;
  for (const PlaneSpec& plane : p.planes) {
    double lowest = std::numeric_limits<double>::infinity();
    for (int i = 0; i < grid.node_count; ++i) {
      const Eigen::Vector3d x =
          grid.sdf.node_position(grid.node_grid[size_t(i)]) + Eigen::Vector3d(u[3 * i], u[3 * i + 1], u[3 * i + 2]);
      lowest = std::min(lowest, plane.normal.normalized().dot(x) - plane.height);
    }
    out.push_back(lowest);
  }
  return out;
}

struct Accumulator {
  int points = 0, matched = 0;
  double sum = 0, sum_sq = 0;
  void add(const ResidualPoint& p) {
    ++points;
    if (!p.matched) return;
    ++matched;
    sum += p.residual;
    sum_sq += p.residual * p.residual;
  }
  nlohmann::json json() const {
    nlohmann::json j;
    j["points"] = points;
    j["matched"] = matched;
    j["matched_fraction"] = points ? double(matched) / points : 0.0;
    j["rms_m"] = matched ? std::sqrt(sum_sq / matched) : 0.0;
    j["mean_m"] = matched ? sum / matched : 0.0;
    return j;
  }
};

}  // namespace

std::string region_name(int region) {
  return fmt::format("{}x{}y{}z", region & 1 ? '+' : '-', region & 2 ? '+' : '-', region & 4 ? '+' : '-');
}

std::string phase_name(const FrameResiduals& f) {
  return f.phase == "contact" ? fmt::format("contact with plane {}", f.plane) : f.phase;
}

Residuals compute_residuals(const Problem& problem, const PhysicalParameters& params, const std::string& device) {
  Residuals r;
  Simulation sim(problem.scene, problem.grid, 1, true);
  place_on(sim, device);
  sim.set_parameters(0, params);
  r.rest_centre = sim.center_of_mass(0);
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  // The contact threshold: the soft-min force acts within a few 1/alpha of a plane.
  std::vector<double> reach;
  for (const PlaneSpec& p : params.planes) reach.push_back(3.0 / p.softmin_alpha + 0.02 * problem.grid.h);
  bool touched = false;
  std::vector<bool> was_touching(params.planes.size(), false);
  int step = 0;
  for (size_t f = 0; f < problem.frames.size(); ++f) {
    const ObservedFrame& frame = problem.frames[f];
    while (step < frame.step) sim.step(), ++step;
    const double* u = sim.displacement(0);
    const double* band = sim.band_displacement(0);
    FrameResiduals fr;
    fr.frame = int(f);
    fr.step = frame.step;
    fr.time = frame.step * sim.dt();
    const std::vector<double> clearance = plane_clearances(problem.grid, params, u);
    int touching = -1, nearest = -1;
    for (size_t k = 0; k < clearance.size(); ++k) {
      if (nearest < 0 || clearance[k] < clearance[size_t(nearest)]) nearest = int(k);
      const bool now = clearance[k] < reach[k];
      if (now && touching < 0) touching = int(k);
      if (now && !was_touching[k] && f > 0) r.contact_times.push_back(fr.time);
      was_touching[k] = now;
    }
    touched |= touching >= 0;
    fr.phase = touching >= 0 ? "contact" : touched ? "after contact" : "flight";
    fr.plane = touching >= 0 ? touching : nearest;
    const Eigen::Vector3d plane_normal =
        fr.plane >= 0 ? params.planes[size_t(fr.plane)].normal.normalized() : Eigen::Vector3d(-params.gravity.normalized());
    fr.cost = cost.evaluate(frame.points, frame.weight, u, band, nullptr, nullptr).cost;
    const std::vector<SurfaceConstraintCost::PointResidual> pr = cost.point_residuals(frame.points, u, band);
    // Observed points are in camera order, each camera's measured pixels row by row.
    int camera = 0, pixel = -1;
    const std::vector<DepthImage>* images =
        f < problem.observations.frames.size() ? &problem.observations.frames[f] : nullptr;
    auto next_pixel = [&]() {
      while (images && camera < int(images->size())) {
        const DepthImage& im = (*images)[size_t(camera)];
        while (++pixel < im.width * im.height)
          if (im.depth[size_t(pixel)] > 0) return;
        ++camera, pixel = -1;
      }
    };
    Accumulator acc;
    for (size_t i = 0; i < frame.points.size(); ++i) {
      next_pixel();
      ResidualPoint p;
      p.frame = int(f);
      p.camera = camera;
      p.pixel = pixel;
      p.world = frame.points[i];
      p.matched = pr[i].matched();
      if (p.matched) {
        p.residual = pr[i].phi;
        p.rest = pr[i].rest;
        p.normal = pr[i].normal;
        const Eigen::Vector3d d = p.residual * pr[i].normal;
        p.normal_part = d.dot(plane_normal);
        p.tangential_part = (d - p.normal_part * plane_normal).norm();
        const Eigen::Vector3d o = p.rest - r.rest_centre;
        p.region = (o.x() > 0) | (o.y() > 0) << 1 | (o.z() > 0) << 2;
      }
      acc.add(p);
      r.points.push_back(p);
    }
    fr.points = acc.points;
    fr.matched = acc.matched;
    fr.rms = acc.matched ? std::sqrt(acc.sum_sq / acc.matched) : 0.0;
    fr.mean = acc.matched ? acc.sum / acc.matched : 0.0;
    r.frames.push_back(fr);
  }
  return r;
}

nlohmann::json residual_summary(const Residuals& r) {
  nlohmann::json j;
  Accumulator all;
  std::map<std::string, Accumulator> by_phase;
  std::map<int, Accumulator> by_region;
  double normal_sq = 0, tangential_sq = 0;
  int matched = 0;
  for (const ResidualPoint& p : r.points) {
    const FrameResiduals& f = r.frames[size_t(p.frame)];
    all.add(p);
    by_phase[phase_name(f)].add(p);
    if (!p.matched) continue;
    by_region[p.region].add(p);
    normal_sq += p.normal_part * p.normal_part;
    tangential_sq += p.tangential_part * p.tangential_part;
    ++matched;
  }
  j["all"] = all.json();
  j["by_phase"] = nlohmann::json::object();
  for (const auto& [name, a] : by_phase) j["by_phase"][name] = a.json();
  j["by_region"] = nlohmann::json::object();
  for (const auto& [region, a] : by_region) j["by_region"][region_name(region)] = a.json();
  j["by_direction"] = {{"normal_rms_m", matched ? std::sqrt(normal_sq / matched) : 0.0},
                       {"tangential_rms_m", matched ? std::sqrt(tangential_sq / matched) : 0.0},
                       {"relative_to", "the contact plane's normal (the nearest plane when in flight)"}};
  nlohmann::json frames = nlohmann::json::array();
  for (const FrameResiduals& f : r.frames)
    frames.push_back({{"frame", f.frame},     {"step", f.step},   {"time_s", f.time}, {"phase", f.phase},
                      {"plane", f.plane},     {"points", f.points}, {"matched", f.matched},
                      {"rms_m", f.rms},       {"mean_m", f.mean}, {"cost", f.cost}});
  j["by_frame"] = frames;
  j["contact_times_s"] = r.contact_times;
  return j;
}

std::string residuals_csv(const Residuals& r) {
  std::string s =
      "frame,time_s,camera,pixel,x,y,z,matched,residual_m,rest_x,rest_y,rest_z,region,normal_m,tangential_m,phase\n";
  for (const ResidualPoint& p : r.points) {
    const FrameResiduals& f = r.frames[size_t(p.frame)];
    s += fmt::format("{},{:.6g},{},{},{:.6g},{:.6g},{:.6g},{},", p.frame, f.time, p.camera, p.pixel, p.world.x(),
                     p.world.y(), p.world.z(), p.matched ? 1 : 0);
    if (p.matched)
      s += fmt::format("{:.6g},{:.6g},{:.6g},{:.6g},{},{:.6g},{:.6g},", p.residual, p.rest.x(), p.rest.y(), p.rest.z(),
                       region_name(p.region), p.normal_part, p.tangential_part);
    else
      s += ",,,,,,,";
    s += f.phase + "\n";
  }
  return s;
}

}  // namespace ssc
