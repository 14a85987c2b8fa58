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
#include "models/observation/depth_render.h"
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
    const double* band = sim.band_displacement(0);
    const std::vector<double> phi = cost.point_phi(frame.points, sim.displacement(0), band);
    const std::vector<Eigen::Vector3d> verts = surface.positions(sim.displacement(0));
    std::string svg = fmt::format(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" font-family=\"sans-serif\" font-size=\"12\">\n"
        "<defs><linearGradient id=\"phi\"><stop offset=\"0\" stop-color=\"{2}\"/><stop offset=\"0.5\" stop-color=\"{3}\"/>"
        "<stop offset=\"1\" stop-color=\"{4}\"/></linearGradient></defs>\n"
        "<rect width=\"100%\" height=\"100%\" fill=\"#f8f8f8\"/>\n<g fill=\"#c9d3e0\" shape-rendering=\"crispEdges\">\n",
        cam.width * scale, cam.height * scale + 62, residual_color(0, 1), residual_color(0.5, 1), residual_color(1, 1));
    // The fitted surface as the camera sees it: its silhouette rendered at the camera's own
    // resolution, one rectangle per run of covered pixels in a row (a few kB, where one
    // polygon per surface triangle made megabytes).
    const DepthImage seen = render_depth(cam, TriangleBvh(verts, surface.triangles()), 0.0, 0);
    for (int v = 0; v < seen.height; ++v)
      for (int u = 0; u < seen.width;) {
        if (!(seen.at(u, v) > 0)) {
          ++u;
          continue;
        }
        int end = u;
        while (end < seen.width && seen.at(end, v) > 0) ++end;
        svg += fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\"/>\n", u * scale, v * scale,
                           (end - u) * scale, scale);
        u = end;
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
    const double bar_y = cam.height * scale + 40;
    svg += fmt::format("<text x=\"6\" y=\"{:.0f}\">frame {} (step {}, t = {:.3f} s), camera {}: {} observed points</text>\n"
                       "<text x=\"6\" y=\"{:.0f}\">distance of each observed point to the fitted surface, |phi|; grey: unmatched</text>\n"
                       "<rect x=\"6\" y=\"{:.0f}\" width=\"200\" height=\"10\" fill=\"url(#phi)\" stroke=\"#666\" stroke-width=\"0.5\"/>"
                       "<text x=\"6\" y=\"{:.0f}\" font-size=\"10\">0</text>"
                       "<text x=\"206\" y=\"{:.0f}\" font-size=\"10\" text-anchor=\"end\">{:.3g} mm (phi_max)</text>"
                       "<circle cx=\"230\" cy=\"{:.0f}\" r=\"4\" fill=\"{}\"/><text x=\"238\" y=\"{:.0f}\" font-size=\"10\">unmatched</text>\n</svg>\n",
                       cam.height * scale + 16, f, frame.step, frame.step * problem.scene.time.dt, cam.name, shown,
                       cam.height * scale + 32, bar_y, bar_y + 20, bar_y + 20, 1e3 * problem.phi_max, bar_y + 5,
                       residual_color(std::nan(""), 1), bar_y + 9);
    const std::string name = fmt::format("fit_frame_{:04d}.svg", f);
    write_text_file(out.file(name), svg);
    written.push_back(name);
  }
  return written;
}

}  // namespace ssc
