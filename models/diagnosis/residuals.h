// Where a simulation disagrees with the observations: for every observed depth point of
// every frame and camera, its signed distance to the simulated surface (the sparse surface
// constraint's phi, metres; positive outside the body), where on the rest shape it matched,
// and its split into the parts normal and tangential to the nearest contact plane; and the
// same aggregated by frame (time), by phase of the motion (flight, contact with plane k,
// after contact), by region of the body (octants of the rest shape about its centre of
// mass) and by direction. Unmatched points (no simulated cell contains them) are counted,
// not given a residual.
#pragma once
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/sim/parameters.h"
#include "models/sim/problem.h"

namespace ssc {

struct ResidualPoint {
  int frame = 0, camera = 0, pixel = 0;  // pixel: row * width + column of its camera
  Eigen::Vector3d world = Eigen::Vector3d::Zero();
  bool matched = false;
  double residual = 0;                                // phi, metres
  Eigen::Vector3d rest = Eigen::Vector3d::Zero();     // where it matched on the rest shape
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();   // the simulated surface's outward unit normal there
  double normal_part = 0, tangential_part = 0;        // of phi * (surface normal), along the plane's normal / across it
  int region = 0;                                     // octant bits: x, y, z above the rest centre of mass
};

struct FrameResiduals {
  int frame = 0, step = 0;
  double time = 0;
  std::string phase;   // "flight", "contact", "after contact"
  int plane = -1;      // the plane touched (contact) or nearest (otherwise); -1 without planes
  int points = 0, matched = 0;
  double rms = 0, mean = 0;  // of the matched points' residuals, metres
  double cost = 0;           // the frame's J_SSC term
};

struct Residuals {
  std::vector<FrameResiduals> frames;
  std::vector<ResidualPoint> points;
  Eigen::Vector3d rest_centre = Eigen::Vector3d::Zero();
  std::vector<double> contact_times;  // times at which a contact with a plane begins
};

// Simulates the problem's scene with `params` (on the GPU for device "cuda") and measures
// every observed frame.
Residuals compute_residuals(const Problem& problem, const PhysicalParameters& params, const std::string& device = "cpu");

// The aggregates as JSON: matched fraction, RMS and mean residual (metres) by frame, phase,
// region and direction.
nlohmann::json residual_summary(const Residuals& r);

// One row per observed point.
std::string residuals_csv(const Residuals& r);

// Octant name of a region index, e.g. "+x-y+z".
std::string region_name(int region);

// The phase a frame is grouped under: "flight", "contact with plane k" or "after contact".
std::string phase_name(const FrameResiduals& f);

}  // namespace ssc
