// Scratch version: measuring.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/io/errors.h"
#include "models/optim/optimizer.h"
#include "models/optim/parameter_space.h"
#include "models/optim/reconstruction.h"
#include "models/sim/body.h"
#include "models/sim/observation_setup.h"
#include "models/sim/parameters.h"
#include "models/sim/problem.h"

namespace ssc {
namespace {

using Vec = Eigen::VectorXd;
using Objective = std::function<double(const Vec&, Vec*)>;

struct Trace {
  std::vector<Vec> points;
  std::vector<double> costs;
};

Trace drive(Optimizer& opt, const Objective& f, int max_evaluations) {
  Trace t;
  while (!opt.done() && int(t.costs.size()) < max_evaluations) {
    const Vec x = opt.ask();
    Vec g;
    const double c = f(x, &g);
    t.points.push_back(x);
    t.costs.push_back(c);
    opt.tell(c, g);
  }
  return t;
}

Eigen::MatrixXd quadratic_matrix() {
  Eigen::MatrixXd m(5, 5);
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) m(i, j) = std::sin(1.0 + 5 * i + j);
  const Eigen::MatrixXd q = Eigen::HouseholderQR<Eigen::MatrixXd>(m).householderQ();
  Vec lambda(5);
  for (int i = 0; i < 5; ++i) lambda[i] = std::pow(100.0, i / 4.0);
  return q * lambda.asDiagonal() * q.transpose();
}

TEST(OptimScratch, Measure) {
  const Eigen::MatrixXd A = quadratic_matrix();
  Vec c(5);
  c << 1, -2, 0.5, 3, -1;
  Objective quad = [&](const Vec& x, Vec* g) {
    *g = A * (x - c);
    return 0.5 * (x - c).dot(A * (x - c));
  };
  Objective rosen = [](const Vec& x, Vec* g) {
    g->resize(2);
    (*g)[0] = -2 * (1 - x[0]) - 400 * x[0] * (x[1] - x[0] * x[0]);
    (*g)[1] = 200 * (x[1] - x[0] * x[0]);
    return (1 - x[0]) * (1 - x[0]) + 100 * (x[1] - x[0] * x[0]) * (x[1] - x[0] * x[0]);
  };
  Objective one = [](const Vec& x, Vec* g) {
    g->resize(1);
    (*g)[0] = std::exp(x[0]) - 2;
    return std::exp(x[0]) - 2 * x[0];
  };
  for (int its : {50, 100, 200, 500, 1000, 3000}) {
    for (const std::string& name : optimizer_names()) {
      OptimizerOptions o;
      o.max_iterations = its;
      {
        auto opt = make_optimizer(name, Vec::Zero(5), o);
        Trace t = drive(*opt, quad, 100000);
        std::printf("quad  %5d %-12s its %5d evals %6zu err %.3e cost %.3e reason %s\n", its, name.c_str(), opt->iterations(),
                    t.costs.size(), (opt->best_point() - c).norm(), opt->best_cost(), opt->stop_reason().c_str());
      }
      {
        Vec x0(2);
        x0 << -1.2, 1;
        auto opt = make_optimizer(name, x0, o);
        Trace t = drive(*opt, rosen, 100000);
        std::printf("rosen %5d %-12s its %5d evals %6zu err %.3e cost %.3e reason %s\n", its, name.c_str(), opt->iterations(),
                    t.costs.size(), (opt->best_point() - Vec::Ones(2)).norm(), opt->best_cost(), opt->stop_reason().c_str());
      }
      {
        auto opt = make_optimizer(name, Vec::Constant(1, 3.0), o);
        Trace t = drive(*opt, one, 100000);
        std::printf("one   %5d %-12s its %5d evals %6zu err %.3e reason %s\n", its, name.c_str(), opt->iterations(), t.costs.size(),
                    std::abs(opt->best_point()[0] - std::log(2.0)), opt->stop_reason().c_str());
      }
    }
  }
}

TEST(OptimScratch, Rosen) {
  Objective rosen = [](const Vec& x, Vec* g) {
    g->resize(2);
    (*g)[0] = -2 * (1 - x[0]) - 400 * x[0] * (x[1] - x[0] * x[0]);
    (*g)[1] = 200 * (x[1] - x[0] * x[0]);
    return (1 - x[0]) * (1 - x[0]) + 100 * (x[1] - x[0] * x[0]) * (x[1] - x[0] * x[0]);
  };
  double starts[5][2] = {{-1.2, 1}, {-1.5, 2}, {0, 0}, {2, 2}, {0.5, -0.5}};
  for (auto& s : starts)
  for (int its : {1000, 2000, 3000, 5000, 10000}) {
    for (const std::string& name : optimizer_names()) {
      OptimizerOptions o;
      o.max_iterations = its;
      Vec x0(2);
      x0 << s[0], s[1];
      auto opt = make_optimizer(name, x0, o);
      Trace t = drive(*opt, rosen, 100000);
      std::printf("rosen (%g,%g) %5d %-12s its %5d evals %6zu err %.3e cost %.3e reason %s\n", s[0], s[1], its, name.c_str(), opt->iterations(),
                  t.costs.size(), (opt->best_point() - Vec::Ones(2)).norm(), opt->best_cost(), opt->stop_reason().c_str());
    }
  }
}

using json = nlohmann::json;

json sphere_scene(double E, double cell, int steps, int cam_px, double noise) {
  json j;
  j["object"] = {{"primitive", "sphere"}, {"radius", 0.25}, {"position", {0.0, 0.3, 0.0}}};
  j["grid"] = {{"cell_size", cell}, {"band_width", 2}};
  j["material"] = {{"youngs_modulus", E}, {"poisson_ratio", 0.3}, {"density", 100}, {"mass_damping", 0.1}, {"stiffness_damping", 0.01}};
  j["gravity"] = {0, -9.81, 0};
  j["initial"] = {{"linear_velocity", {0.0, -2.0, 0.0}}, {"angular_velocity", {0.0, 0.0, 0.0}}};
  j["ground"] = {{"height", 0.0}, {"normal", {0.0, 1.0, 0.0}}, {"stiffness", 3e5}, {"softmin_alpha", 100}};
  j["time"] = {{"dt", 0.01}, {"steps", steps}, {"theta", 0.6}};
  json cams = json::array();
  cams.push_back({{"name", "a"}, {"width", cam_px}, {"height", cam_px}, {"fov_deg", 40}, {"eye", {1.2, 0.8, 1.0}}, {"target", {0, 0.2, 0}}, {"min_depth", 0.2}, {"max_depth", 5.0}});
  cams.push_back({{"name", "b"}, {"width", cam_px}, {"height", cam_px}, {"fov_deg", 40}, {"eye", {-1.3, 0.6, -0.6}}, {"target", {0, 0.2, 0}}, {"min_depth", 0.2}, {"max_depth", 5.0}});
  j["observation"] = {{"every", 1}, {"noise", noise}, {"seed", 5}, {"depth_scale", 1e-4}, {"phi_max", 0.1}, {"cameras", cams}};
  return j;
}

Problem make_problem(const json& j) {
  Problem p;
  p.scene = parse_scene(j, "optim_test_sphere.json");
  p.grid = build_body_grid(p.scene);
  const ObservationSpec spec = parse_observation_spec(p.scene);
  p.observations = render_observations(p.scene, p.grid, spec);
  p.frames = observed_frames(p.observations, p.scene.time.dt, "in-memory");
  p.phi_max = spec.phi_max;
  return p;
}

TEST(OptimScratch, Recon) {
  const char* env = std::getenv("SCR");
  double cell = 0.08; int steps = 20; int px = 32; double noise = 0; int its = 20; std::string optn = "rprop";
  if (env) { std::sscanf(env, "%lf %d %d %lf %d", &cell, &steps, &px, &noise, &its); }
  if (std::getenv("OPT")) optn = std::getenv("OPT");
  auto t0 = std::chrono::steady_clock::now();
  Problem p = make_problem(sphere_scene(2e4, cell, steps, px, noise));
  size_t pts = 0; for (auto& f : p.frames) pts += f.points.size();
  std::printf("nodes %d frames %zu points %zu setup %.2fs\n", p.grid.node_count, p.frames.size(), pts,
     std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  ReconstructionOptions o;
  o.fit = {"youngs_modulus"};
  o.optimizer = optn;
  o.optimizer_options.max_iterations = its;
  if (std::getenv("SEED")) { o.seed = std::atoi(std::getenv("SEED")); o.starts = std::atoi(std::getenv("NS")); } else
  for (double f : {0.3, 0.5, 0.9, 1.0, 1.1, 2.0, 4.0}) o.initial_values.push_back(Vec::Constant(1, 2e4 * f));
  ReconstructionResult r = reconstruct(p, o, [](int it, int active, double best, const Vec& x) {
    if (std::getenv("HIST")) std::printf("round %d active %d best %.6g x %.6g\n", it, active, best, x[0]);
  });
  for (auto& s : r.starts) {
    std::printf("start %.4g -> %.6g cost %.6g its %d %s\n", s.initial[0], s.final[0], s.final_cost, s.iterations, s.stop_reason.c_str());
    if (std::getenv("HIST")) for (size_t k = 0; k < s.cost_history.size(); ++k) std::printf("   %zu %.6g %.8g\n", k, s.parameter_history[k][0], s.cost_history[k]);
  }
  std::printf("evals %d wall %.2f\n", r.evaluations, r.wall_seconds);
}

TEST(OptimScratch, Fail) {
  Problem p = make_problem(sphere_scene(2e4, 0.08, 20, 32, 0.005));
  for (double E : {1e3, 1e2, 10.0, 1.0, 1e-1, 1e-2, 1e-4, 1e-8, 1e9, 1e12}) {
    PhysicalParameters q = PhysicalParameters::from_scene(p.scene);
    q.youngs_modulus = E;
    Simulation sim(p.scene, p.grid, 1, true);
    sim.set_parameters(0, q);
    try { for (int t = 0; t < 20; ++t) sim.step(); std::printf("E %g ok, cg its %d\n", E, sim.last_report().cg_iterations.empty() ? -1 : sim.last_report().cg_iterations[0]); }
    catch (const SimulationError& e) { std::printf("E %g failed: %s\n", E, e.what()); }
  }
  for (double rho : {1e-2, 1e-4, 1e-6, 1e6}) {
    PhysicalParameters q = PhysicalParameters::from_scene(p.scene);
    q.density = rho;
    Simulation sim(p.scene, p.grid, 1, true);
    sim.set_parameters(0, q);
    try { for (int t = 0; t < 20; ++t) sim.step(); std::printf("rho %g ok\n", rho); }
    catch (const SimulationError& e) { std::printf("rho %g failed: %s\n", rho, e.what()); }
  }
}

}  // namespace
}  // namespace ssc
