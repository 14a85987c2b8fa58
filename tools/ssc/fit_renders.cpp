// Fit renders (see fit_renders.h).
#include "tools/ssc/fit_renders.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "models/cost/surface_constraint.h"
#include "runtime/errors.h"
#include "models/io/text_file.h"
#include "models/observation/camera.h"
#include "models/sim/deformed_surface.h"
#include "models/sim/parameters.h"
#include "models/sim/simulation.h"

namespace ssc {
namespace {

std::string residual_color(double phi, double phi_max) {
  if (!std::isfinite(phi)) return "#888888";
  const double t = std::min(1.0, std::abs(phi) / phi_max);
  return fmt::format("#{:02x}{:02x}40", int(255 * t), int(200 * (1 - t)));
}

}  // namespace

std::vector<std::string> write_fit_renders(const OutputDir& out, const Problem& problem, const std::vector<std::string>& names,
                                           const Eigen::VectorXd& values) {
  if (problem.frames.empty() || problem.observations.cameras.empty()) return {};
  PhysicalParameters p = PhysicalParameters::from_scene(problem.scene);
  for (size_t i = 0; i < names.size(); ++i) set_parameter(p, names[i], values[i]);
  Simulation sim(problem.scene, problem.grid, 1, true);
  sim.set_parameters(0, p);
  const DeformedSurface surface(problem.grid);
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  const DepthCamera& cam = problem.observations.cameras[0];
  const int n = int(problem.frames.size());
  std::vector<int> picks = {std::min(1, n - 1), n / 2, n - 1};
  picks.erase(std::unique(picks.begin(), picks.end()), picks.end());
  std::vector<std::string> written;
  const double scale = 480.0 / std::max(cam.width, cam.height);
  for (int f : picks) {
    const ObservedFrame& frame = problem.frames[f];
    while (sim.steps_taken() < frame.step) sim.step();
    const std::vector<double> zero_band(3 * size_t(problem.grid.band_count), 0.0);
    const double* band = frame.step == 0 ? zero_band.data() : sim.band_displacement(0);
    const std::vector<double> phi = cost.point_phi(frame.points, sim.displacement(0), band);
    const std::vector<Eigen::Vector3d> verts = surface.positions(sim.displacement(0));
    std::string svg = fmt::format(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" font-family=\"sans-serif\" font-size=\"12\">\n"
        "<rect width=\"100%\" height=\"100%\" fill=\"#f8f8f8\"/>\n<g fill=\"#c9d3e0\" stroke=\"#aab6c6\" stroke-width=\"0.3\">\n",
        cam.width * scale, cam.height * scale + 40);
    for (const auto& t : surface.triangles()) {
      std::string pts;
      bool visible = true;
      for (int k = 0; k < 3; ++k) {
        double u, v, d;
        visible &= project(cam, verts[t[k]], &u, &v, &d);
        pts += fmt::format("{:.1f},{:.1f} ", (u + 0.5) * scale, (v + 0.5) * scale);
      }
      if (visible) svg += fmt::format("<polygon points=\"{}\"/>\n", pts);
    }
    svg += "</g>\n";
    int shown = 0;
    for (size_t i = 0; i < frame.points.size(); ++i) {
      double u, v, d;
      if (!project(cam, frame.points[i], &u, &v, &d)) continue;  // points of other cameras may fall outside
      if (u < -0.5 || v < -0.5 || u > cam.width - 0.5 || v > cam.height - 0.5) continue;
      svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" fill=\"{}\"/>\n", (u + 0.5) * scale, (v + 0.5) * scale,
                         std::max(1.0, 0.3 * scale), residual_color(phi[i], problem.phi_max));
      ++shown;
    }
    svg += fmt::format("<text x=\"6\" y=\"{:.0f}\">frame {} (step {}, t = {:.3f} s), camera {}: {} observed points</text>\n"
                       "<text x=\"6\" y=\"{:.0f}\">colour: |phi| from 0 (green) to phi_max = {:.3g} m (red), grey: unmatched</text>\n</svg>\n",
                       cam.height * scale + 16, f, frame.step, frame.step * problem.scene.time.dt, cam.name, shown,
                       cam.height * scale + 32, problem.phi_max);
    const std::string name = fmt::format("fit_frame_{:04d}.svg", f);
    write_text_file(out.file(name), svg);
    written.push_back(name);
  }
  return written;
}

}  // namespace ssc
