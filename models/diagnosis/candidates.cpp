// The diagnosis's models (see candidates.h).
#include "models/diagnosis/candidates.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "models/sim/parameters.h"
#include "models/sim/timestep_graph.h"

namespace ssc {
namespace {

constexpr double kParallelPlane = 0.97;  // cos 14 degrees

}  // namespace

std::string plane_parameter(int k, const std::string& key) {
  return k == 0 ? "ground." + key : fmt::format("ground.planes[{}].{}", k, key);
}

int extra_parameter_count(const ExtensionRow& row, const Scene& scene) {
  // The others' parameters (a new plane's height, a new region's modulus) are scalars the
  // scene does not have yet.
  if (row.fit != ExtensionRow::Fit::OffValue) return int(row.parameters(scene).size());
  return int(expand_parameter_names(row.parameters(scene), PhysicalParameters::from_scene(scene)).size());
}

ModelSpec candidate_spec(const ExtensionRow& row, const Scene& scene, double extent) {
  ModelSpec spec{row.name};
  spec.overrides = row.overrides;
  if (row.fit != ExtensionRow::Fit::OffValue) return spec;
  spec.extra = row.parameters(scene);
  spec.log_range = row.log_start;
  for (const std::string& name : expand_parameter_names(spec.extra, PhysicalParameters::from_scene(scene))) {
    spec.ranges[name] = row.start_range(extent);
    if (!row.one_sided) spec.magnitudes[name] = row.typical(extent);
  }
  return spec;
}

// The placebo's parameters, in the order they are taken: those the body's motion does not
// use first (the horizontal linear components the scene gives as 0, then the spin's), those
// of its motion last (the other horizontal ones, slowest first, then the vertical). Freedom
// to fit the held-in frames that no missing effect stands behind. The components of the
// motion come last because they are not without meaning: a slower throw mimics air drag, as
// a constant force mimics friction.
std::vector<std::string> placebo_parameters(const Scene& scene, const std::vector<std::string>& base_fit) {
  const PhysicalParameters p = PhysicalParameters::from_scene(scene);
  const std::vector<std::string> fitted = expand_parameter_names(base_fit, p);
  const Eigen::Vector3d g = p.gravity.cwiseAbs();
  int along = 0;
  for (int a = 1; a < 3; ++a)
    if (g[a] > g[along]) along = a;
  auto linear = [](int a) { return std::string("initial.linear_velocity.") + "xyz"[a]; };
  std::vector<int> still, moving;
  for (int a = 0; a < 3; ++a)
    if (a != along) (get_parameter(p, linear(a)) == 0 ? still : moving).push_back(a);
  std::stable_sort(moving.begin(), moving.end(), [&](int a, int b) {
    return std::abs(get_parameter(p, linear(a))) < std::abs(get_parameter(p, linear(b)));
  });
  std::vector<std::string> order;
  for (int a : still) order.push_back(linear(a));
  for (int a = 0; a < 3; ++a) order.push_back(std::string("initial.angular_velocity.") + "xyz"[a]);
  for (int a : moving) order.push_back(linear(a));
  order.push_back(linear(along));
  std::vector<std::string> out;
  for (const std::string& name : order)
    if (std::find(fitted.begin(), fitted.end(), name) == fitted.end()) out.push_back(name);
  return out;
}

ModelSpec placebo_spec(const Scene& scene, const std::vector<std::string>& spare, int k) {
  ModelSpec placebo{fmt::format("placebo_{}", k)};
  const PhysicalParameters p = PhysicalParameters::from_scene(scene);
  for (int i = 0; i < k; ++i) {
    placebo.extra.push_back(spare[size_t(i)]);
    const double v0 = get_parameter(p, spare[size_t(i)]);
    placebo.ranges[spare[size_t(i)]] = {v0 - 0.2, v0 + 0.2};  // m/s (rad/s for a spin)
  }
  return placebo;
}

std::vector<ModelSpec> plane_proposals(const FittedModel& base, int heldin, int most) {
  const Problem& p = base.problem;
  const PhysicalParameters params = with_values(p.scene, base.names, base.values);
  const Eigen::Vector3d up = -params.gravity.normalized();
  const Eigen::Vector3d e1 = up.unitOrthogonal(), e2 = up.cross(e1);
  std::vector<Eigen::Vector3d> directions;
  for (int a = 0; a < 8; ++a) directions.push_back(std::cos(a * M_PI / 4) * e1 + std::sin(a * M_PI / 4) * e2);
  directions.push_back(up);
  directions.push_back(-up);
  const size_t D = directions.size();
  // Per direction: the gap (simulated extreme - observed extreme) in the first observed frame,
  // the largest gap beyond it, and the farthest the observed body reached: a surface stops it
  // there, and it may come back before the gap is largest (a wall it bounced off).
  std::vector<double> first_gap(D, std::nan("")), over(D, 0), reach(D, -1e300), observed_at(D, 0);
  Simulation sim(p.scene, p.grid, 1, false);
  sim.set_parameters(0, params);
  int step = 0;
  for (int f = 0; f < heldin; ++f) {
    const ObservedFrame& frame = p.frames[size_t(f)];
    while (step < frame.step) sim.step(), ++step;
    if (frame.points.empty()) continue;
    const double* u = sim.displacement(0);
    for (size_t d = 0; d < D; ++d) {
      double observed = -1e300, simulated = -1e300;
      for (const Eigen::Vector3d& x : frame.points) observed = std::max(observed, x.dot(directions[d]));
      for (int i = 0; i < p.grid.node_count; ++i) {
        const Eigen::Vector3d x =
            p.grid.sdf.node_position(p.grid.node_grid[size_t(i)]) + Eigen::Vector3d(u[3 * i], u[3 * i + 1], u[3 * i + 2]);
        simulated = std::max(simulated, x.dot(directions[d]));
      }
      const double gap = simulated - observed;
      if (std::isnan(first_gap[d])) first_gap[d] = gap;
      over[d] = std::max(over[d], gap - first_gap[d]);
      reach[d] = std::max(reach[d], observed);
    }
  }
  for (size_t d = 0; d < D; ++d) observed_at[d] = reach[d] + (std::isnan(first_gap[d]) ? 0 : first_gap[d]);
  // A plane facing as one of the scene's does is that plane's offset, not a second surface.
  auto new_surface = [&](size_t d) {
    return std::none_of(p.scene.planes.begin(), p.scene.planes.end(), [&](const PlaneSpec& plane) {
      return -directions[d].dot(plane.normal.normalized()) > kParallelPlane;
    });
  };
  // A plane the body would start beyond (it went that way and came back, say) is no proposal:
  // the scene could not even start. Half a cell of room, as the soft-min contact needs.
  auto clear_of_start = [&](size_t d) {
    double rest = -1e300;
    for (int i = 0; i < p.grid.node_count; ++i)
      rest = std::max(rest, p.grid.node_start(i).dot(directions[d]));
    return rest + 0.5 * p.grid.h < observed_at[d];
  };
  std::vector<size_t> order;
  for (size_t d = 0; d < D; ++d)
    if (over[d] > 0.5 * p.grid.h && new_surface(d) && clear_of_start(d)) order.push_back(d);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return over[a] > over[b]; });
  std::vector<size_t> chosen;
  for (size_t d : order)
    if (int(chosen.size()) < most &&
        std::all_of(chosen.begin(), chosen.end(), [&](size_t c) { return directions[c].dot(directions[d]) < 0.5; }))
      chosen.push_back(d);

  const int planes = int(p.scene.planes.size());
  const PlaneSpec first = planes > 0 ? p.scene.planes[0] : PlaneSpec{};
  const std::string height = plane_parameter(planes, "height");
  std::vector<ModelSpec> specs;
  for (size_t n = 0; n < chosen.size(); ++n) {
    const size_t d = chosen[n];
    ModelSpec spec{"second_plane"};
    spec.extra = {height};
    spec.extra_in_load = false;
    PlaneSpec plane = first;
    plane.normal = -directions[d];  // n . x >= height keeps the body on the observed side
    plane.height = -observed_at[d];
    plane.friction = 0;
    spec.ranges[height] = {plane.height - 2 * p.grid.h, plane.height + 2 * p.grid.h};
    // Every proposal's adjust makes the same scene shape (one plane more), so that proposals
    // fitted as one batch share a graph; each holds its own plane's angles.
    spec.adjust = [planes, plane](Problem& q) {
      if (int(q.scene.planes.size()) == planes) q.scene.planes.push_back(plane);
      q.scene.planes[size_t(planes)] = plane;
    };
    PhysicalParameters with_plane = params;
    with_plane.planes.push_back(plane);
    for (const char* angle : {"polar_deg", "azimuth_deg"}) {
      const std::string name = plane_parameter(planes, angle);
      spec.fixed[name] = get_parameter(with_plane, name);
    }
    spec.note = fmt::format("a plane facing ({:.2f}, {:.2f}, {:.2f}) at {:.3f} m, where the fitted body went {:.1f} mm "
                            "beyond the observations",
                            plane.normal.x(), plane.normal.y(), plane.normal.z(), plane.height, 1e3 * over[d]);
    specs.push_back(spec);
  }
  return specs;
}

InterfaceGuess interface_proposal(const FittedModel& gradient_fit, const Problem& base, double extent) {
  InterfaceGuess guess;
  const std::map<std::string, double> v = values_by_name(gradient_fit);
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  for (int a = 0; a < 3; ++a)
    if (const auto it = v.find(std::string("material.stiffness_gradient.") + "xyz"[a]); it != v.end()) g[a] = it->second;
  // A gradient that changes the modulus by less than 10 % across the body proposes nothing.
  if (gradient_fit.failed || !(g.norm() * extent > 0.1)) return guess;
  guess.normal = g.normalized();
  guess.offset = guess.normal.dot(base.grid.start_center_of_mass());
  const auto e = v.find("youngs_modulus");
  const double modulus = e != v.end() ? e->second : base.scene.material.youngs_modulus;
  // Each side's mean modulus under the gradient, about E exp(+-|g| L / 4): the soft side's is
  // the body's, not the homogeneous base's (which a stiff part can drive far too stiff).
  guess.modulus = modulus * std::exp(g.norm() * extent / 4);
  guess.body_modulus = modulus * std::exp(-g.norm() * extent / 4);
  return guess;
}

ModelSpec two_materials_spec(const Eigen::Vector3d& normal, double offset, double modulus, const std::string& note) {
  ModelSpec spec{"two_materials"};
  spec.overrides = {fmt::format("material.regions=[{{\"normal\":[{},{},{}],\"offset\":{},"
                                "\"youngs_modulus\":{}}}]",
                                normal.x(), normal.y(), normal.z(), offset, modulus)};
  spec.extra = {"material.regions[0].youngs_modulus"};
  spec.ranges[spec.extra[0]] = {modulus / 3, modulus * 3};
  spec.log_range = true;
  spec.note = note;
  return spec;
}

const std::vector<std::string>& discretization_controls() {
  static const std::vector<std::string> names = {"finer_grid", "finer_step"};
  return names;
}

ModelSpec discretization_spec(const std::string& control, const Scene& scene, std::string* skipped) {
  return control == "finer_step" ? finer_step_spec(scene) : finer_grid_spec(scene, skipped);
}

ModelSpec finer_step_spec(const Scene& scene) {
  ModelSpec spec{"finer_step"};
  spec.overrides = {fmt::format("time.dt={}", scene.time.dt / 2), fmt::format("time.steps={}", 2 * scene.time.steps)};
  spec.note = fmt::format("half the time step, time.dt {:g} s", scene.time.dt / 2);
  // The integrator's own damping, (theta - 1/2) dt, a quarter of the base's; the step's
  // nonlinear iterations (where it iterates) twice as many: a step nearer convergence in every
  // way the scene sets, not only in dt.
  if (scene.time.theta > 0.5) {
    const double theta = 0.5 + (scene.time.theta - 0.5) / 2;
    spec.overrides.push_back(fmt::format("time.theta={}", theta));
    spec.note += fmt::format(", theta {:g}", theta);
  }
  if (timestep_model(scene).iterates(int(scene.planes.size()))) {
    const int iterations = std::min(50, 2 * scene.solver.nonlinear_iterations);
    spec.overrides.push_back(fmt::format("solver.nonlinear_iterations={}", iterations));
    spec.note += fmt::format(", {} nonlinear iterations", iterations);
  }
  return spec;
}

ModelSpec finer_grid_spec(const Scene& scene, std::string* skipped) {
  ModelSpec spec{"finer_grid"};
  if (scene.cell_size > 0) {
    spec.overrides.push_back(fmt::format("grid.cell_size={}", scene.cell_size / 2));
    spec.note = fmt::format("a grid of half the cell size, grid.cell_size {:g} m", scene.cell_size / 2);
  } else if (scene.cell_size < 0 && -2 * scene.cell_size <= 300) {
    spec.overrides.push_back(fmt::format("grid.resolution={}", int(-2 * scene.cell_size)));
    spec.note = fmt::format("a grid of half the cell size, grid.resolution {}", int(-2 * scene.cell_size));
  } else {
    *skipped = scene.cell_size == 0 ? "the body's grid is its sdf_file's and cannot be refined"
                                    : "grid.resolution is already above 150 cells";
    spec.name.clear();
    return spec;
  }
  // The same extension band in metres.
  if (scene.grid.band_width > 0) spec.overrides.push_back(fmt::format("grid.band_width={}", 2 * scene.grid.band_width));
  return spec;
}

}  // namespace ssc
