// The whole-simulation gradient (models/sim/gradient.h, evaluate_cost_gradient) against
// central finite differences of the implemented cost, per parameter (level v of the test
// pyramid, docs/decisions.md E3), plus checkpointing, batching and determinism.
//
// Scene: a sphere (radius 0.3 m, cells 0.1 m) spinning and translating onto a tilted
// ground plane, with gravity, Rayleigh damping, corotation, soft-min contact and the
// displacement extension (a band of 2 cells); 12 steps of 10 ms, solver tolerances 1e-12
// (time step) and 1e-13 (extension). Observations: two 40x32 depth cameras
// (make_look_at_camera, render_depth with 2 cm noise along the rays, fixed seeds) render
// the deformed surface (DeformedSurface) of a reference run whose Young's modulus is 1.6x
// larger; every measured pixel is unprojected to a world point (camera unproject), one
// frame per step. The cost is the sparse surface constraint (SurfaceConstraintCost,
// phi_max 0.1 m); thanks to the noise part of the points match cells with band corners,
// so the extension's adjoint is on the path.
//
// Every probe resets the simulation (evaluate_cost_gradient starts from reset()), so no
// state leaks between probes. FD steps are per parameter, in the middle of the plateau
// of a sweep over 1e-3..1e-9 (absolute; relative for E): larger steps show truncation
// (contact is sharp: softmin alpha = 100/m), smaller ones round-off and solver noise. At
// these steps the measured relative errors are 1e-11..5e-9 (the table is printed).
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "models/cost/surface_constraint.h"
#include "models/observation/camera.h"
#include "models/observation/depth_render.h"
#include "models/sim/body.h"
#include "models/sim/deformed_surface.h"
#include "models/sim/gradient.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"
#include "ops/line_search.h"
#include "runtime/interpreter.h"
#include "tests/synthetic_frame_cost.h"

namespace ssc {
namespace {

using json = nlohmann::json;
using Vec3 = Eigen::Vector3d;

constexpr int kSteps = 12;
constexpr double kPhiMax = 0.1;  // m
// Depth noise along the rays (m): it puts part of the observed points outside the body's
// active cells, in cells with extension (band) corners, so that the extension's adjoint
// is exercised too.
constexpr double kNoise = 0.02;

json pipeline_scene_json() {
  json j;
  j["object"] = {{"primitive", "sphere"}, {"radius", 0.3}, {"position", {0.05, 0.345, -0.03}}};
  j["grid"] = {{"cell_size", 0.1}, {"band_width", 2}};
  j["material"] = {{"youngs_modulus", 2e4}, {"poisson_ratio", 0.3}, {"density", 100},
                   {"mass_damping", 0.2},   {"stiffness_damping", 0.01}};
  j["gravity"] = {0, -9.81, 0};
  j["initial"] = {{"linear_velocity", {0.4, -1.2, 0.25}}, {"angular_velocity", {1.5, -2.0, 3.0}}};
  j["ground"] = {{"height", 0.0}, {"normal", {0.15, 1.0, -0.1}}, {"stiffness", 3e5}, {"softmin_alpha", 100}};
  j["time"] = {{"dt", 0.01}, {"steps", kSteps}, {"theta", 0.6}};
  j["solver"] = {{"tolerance", 1e-12}, {"max_iterations", 5000}, {"extension_tolerance", 1e-13}};
  return j;
}

// A clamped bar (no ground, no contact op in the graph): the Dirichlet (fixed-node) paths
// of the time-step solve and of the initial velocity.
json clamped_bar_json() {
  json j;
  j["object"] = {{"primitive", "box"}, {"half_extents", {0.35, 0.08, 0.12}}, {"position", {0.02, 0.5, 0.01}}};
  j["grid"] = {{"cell_size", 0.1}, {"band_width", 2}};
  j["material"] = {{"youngs_modulus", 3e4}, {"poisson_ratio", 0.35}, {"density", 150},
                   {"mass_damping", 0.3},   {"stiffness_damping", 0.015}};
  j["gravity"] = {0.5, -9.81, 0.3};
  j["initial"] = {{"linear_velocity", {0.0, 0.3, -0.2}}, {"angular_velocity", {0.4, 0.0, 0.8}}};
  j["dirichlet"] = {{{"min", {-1.0, 0.0, -1.0}}, {"max", {-0.3, 1.0, 1.0}}}};
  j["time"] = {{"dt", 0.01}, {"steps", kSteps}, {"theta", 0.6}};
  j["solver"] = {{"tolerance", 1e-12}, {"max_iterations", 5000}, {"extension_tolerance", 1e-13}};
  return j;
}

// Scene, grid, observations and cost, built once per scene.
struct Pipeline {
  Scene scene;
  SimGrid grid;
  std::vector<ObservedFrame> frames;
  std::unique_ptr<SurfaceConstraintCost> cost;
  PhysicalParameters params;
  size_t points = 0;
};

// Observations: a reference run whose Young's modulus is 1.6x larger, seen by two cameras
// looking at `target`.
std::unique_ptr<Pipeline> build_pipeline(const json& config, const Vec3& target, const Vec3& eye0, const Vec3& eye1,
                                         const std::function<void(PhysicalParameters&)>& truth = nullptr) {
  auto q = std::make_unique<Pipeline>();
  q->scene = parse_scene(config, "gradient_pipeline_test.json");
  q->grid = build_body_grid(q->scene);
  q->params = PhysicalParameters::from_scene(q->scene);
  PhysicalParameters ref = q->params;
  ref.youngs_modulus *= 1.6;
  if (truth) {
    ref = q->params;
    truth(ref);
  }
  Simulation sim(q->scene, q->grid, 1, false);
  sim.set_parameters(0, ref);
  const DeformedSurface surface(q->grid);
  const Vec3 up(0, 1, 0);
  const std::vector<DepthCamera> cams = {make_look_at_camera("cam0", 40, 32, 35.0, eye0, target, up),
                                         make_look_at_camera("cam1", 40, 32, 35.0, eye1, target, up)};
  for (int t = 1; t <= kSteps; ++t) {
    sim.step();
    const TriangleBvh bvh(surface.positions(sim.displacement(0)), surface.triangles());
    ObservedFrame f;
    f.step = t;
    for (size_t c = 0; c < cams.size(); ++c) {
      const DepthImage img = render_depth(cams[c], bvh, kNoise, mix_seed(7, t, c));
      for (int v = 0; v < img.height; ++v)
        for (int u = 0; u < img.width; ++u)
          if (img.at(u, v) > 0) f.points.push_back(unproject(cams[c], u, v, img.at(u, v)));
    }
    q->points += f.points.size();
    q->frames.push_back(std::move(f));
  }
  q->cost = std::make_unique<SurfaceConstraintCost>(q->grid, kPhiMax);
  return q;
}

const Pipeline& pipeline() {
  static const std::unique_ptr<Pipeline> p =
      build_pipeline(pipeline_scene_json(), Vec3(0.05, 0.3, -0.03), Vec3(1.3, 1.0, 1.5), Vec3(-1.7, 0.7, -0.6));
  return *p;
}

// The sphere with Coulomb friction (mu 0.4) at the tilted ground: it lands spinning and
// sliding, bounces and slides on, so that the contact points stick and slip.
const Pipeline& friction_pipeline() {
  static const std::unique_ptr<Pipeline> p = [] {
    json j = pipeline_scene_json();
    j["ground"]["friction"] = 0.4;
    return build_pipeline(j, Vec3(0.05, 0.3, -0.03), Vec3(1.3, 1.0, 1.5), Vec3(-1.7, 0.7, -0.6));
  }();
  return *p;
}

// The heterogeneous_stiffness extension (two regions, a half-space and a box overriding it,
// and a stiffness gradient) with air drag.
const Pipeline& heterogeneous_pipeline() {
  static const std::unique_ptr<Pipeline> p = [] {
    json j = pipeline_scene_json();
    j["material"]["regions"] = {{{"normal", {0.3, 1, 0}}, {"offset", 0.4}, {"youngs_modulus", 6e4}},
                                {{"min", {-0.3, 0.0, -0.3}}, {"max", {0.05, 0.3, 0.3}}, {"youngs_modulus", 1e4}}};
    j["material"]["stiffness_gradient"] = {1.5, -0.8, 1.0};
    j["air_drag"] = 40.0;
    return build_pipeline(j, Vec3(0.05, 0.3, -0.03), Vec3(1.3, 1.0, 1.5), Vec3(-1.7, 0.7, -0.6));
  }();
  return *p;
}

// The step's nonlinear iterations: implicit contact on a stiffer ground, updated corotation.
const Pipeline& iterating_pipeline() {
  static const std::unique_ptr<Pipeline> p = [] {
    json j = pipeline_scene_json();
    j["ground"]["stiffness"] = 3e6;
    j["solver"]["contact"] = "implicit";
    j["solver"]["corotation"] = "updated";
    j["solver"]["nonlinear_iterations"] = 3;
    return build_pipeline(j, Vec3(0.05, 0.3, -0.03), Vec3(1.3, 1.0, 1.5), Vec3(-1.7, 0.7, -0.6));
  }();
  return *p;
}

// A ground sharp enough (1e7 Pa/m, soft-min alpha 3e3 1/m) that the implicit contact's line
// search scales steps back (ops/line_search.h; the test checks that it does): its step
// length is a constant of the adjoint, exact wherever no probe moves it across a choice. The
// sphere's contact points sit on its cells' own edges (contact_subdivisions 1): with the
// default lattice they are 4x as many with a quarter of the area each, and no step overshoots.
const Pipeline& line_search_pipeline() {
  static const std::unique_ptr<Pipeline> p = [] {
    json j = pipeline_scene_json();
    j["ground"]["stiffness"] = 1e7;
    j["ground"]["softmin_alpha"] = 3e3;
    j["grid"]["contact_subdivisions"] = 1;
    j["solver"]["contact"] = "implicit";
    j["solver"]["nonlinear_iterations"] = 3;
    return build_pipeline(j, Vec3(0.05, 0.3, -0.03), Vec3(1.3, 1.0, 1.5), Vec3(-1.7, 0.7, -0.6));
  }();
  return *p;
}

// The Neo-Hookean material through the step's iterations, with implicit contact and the
// lagged rotation (the iterations' system scaled at each iterate, ops/neo_hookean.h). The CG
// tolerance is 1e-14: at 1e-12 the solves' error is 3e-5 of the tiny spin-about-x gradient.
// (With 3 iterations instead of 4, the central differences need 10x smaller steps: measured
// 7e-3 at the steps below, 1.6e-5 at a tenth of them; the trajectory is more curved there.)
const Pipeline& neo_hookean_pipeline() {
  static const std::unique_ptr<Pipeline> p = [] {
    json j = pipeline_scene_json();
    j["ground"]["stiffness"] = 3e6;
    j["material"]["model"] = "neo_hookean";
    j["solver"]["contact"] = "implicit";
    j["solver"]["nonlinear_iterations"] = 4;
    j["solver"]["tolerance"] = 1e-14;
    return build_pipeline(j, Vec3(0.05, 0.3, -0.03), Vec3(1.3, 1.0, 1.5), Vec3(-1.7, 0.7, -0.6));
  }();
  return *p;
}

const Pipeline& clamped_bar() {
  static const std::unique_ptr<Pipeline> p =
      build_pipeline(clamped_bar_json(), Vec3(0.02, 0.48, 0.01), Vec3(0.8, 1.2, 1.6), Vec3(0.5, 0.1, -1.7));
  return *p;
}

double cost_of(const Pipeline& pl, Simulation& sim, const PhysicalParameters& p) {
  sim.set_parameters(0, p);
  GradientOptions o;
  o.gradient = false;
  return evaluate_cost_gradient(sim, *pl.cost, pl.frames, o)[0].cost;
}

// Tangents of the unit sphere at n.
void tangents(const Vec3& n, Vec3* t1, Vec3* t2) {
  *t1 = n.cross(Vec3(0, 0, 1)).normalized();
  *t2 = n.cross(*t1).normalized();
}

// A scalar parameter: how to perturb it, what the adjoint says about it, its FD step.
struct Probe {
  std::string name;
  double step;
  std::function<void(PhysicalParameters&, double)> perturb;
  std::function<double(const ParameterGradient&)> adjoint;
};

// step_scale shrinks the velocity steps where the central differences' truncation error
// needs it (measured: the heterogeneous sphere's spin about x, 9e-2 at 1e-4 rad/s, 5e-9 at
// 1e-5; the sphere with implicit contact and updated rotation, 7e-2 at 1e-4 about z).
std::vector<Probe> probes(const PhysicalParameters& p0, double step_scale) {
  std::vector<Probe> out;
  // With friction, a contact point whose tangential speed is near the smoothing velocity
  // (1 mm/s) has a curvature of order 1/eps: the velocity and normal steps are 100x (10x)
  // smaller there, else the central differences' truncation error (measured 2.6e-2 at 1e-4
  // rad/s, 6.9e-8 at 1e-6) is what the test sees.
  const bool friction = !p0.planes.empty() && p0.planes[0].friction > 0;
  const double fine = friction ? 0.01 : step_scale;
  out.push_back({"youngs_modulus", 0.2, [](PhysicalParameters& p, double e) { p.youngs_modulus += e; },
                 [](const ParameterGradient& g) { return g.youngs_modulus; }});
  out.push_back({"poisson_ratio", 1e-5, [](PhysicalParameters& p, double e) { p.poisson_ratio += e; },
                 [](const ParameterGradient& g) { return g.poisson_ratio; }});
  out.push_back({"density", 1e-3, [](PhysicalParameters& p, double e) { p.density += e; },
                 [](const ParameterGradient& g) { return g.density; }});
  out.push_back({"mass_damping", 1e-4, [](PhysicalParameters& p, double e) { p.mass_damping += e; },
                 [](const ParameterGradient& g) { return g.mass_damping; }});
  out.push_back({"stiffness_damping", 1e-6, [](PhysicalParameters& p, double e) { p.stiffness_damping += e; },
                 [](const ParameterGradient& g) { return g.stiffness_damping; }});
  const char* axes[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    out.push_back({std::string("gravity.") + axes[k], 1e-4, [k](PhysicalParameters& p, double e) { p.gravity[k] += e; },
                   [k](const ParameterGradient& g) { return g.gravity[k]; }});
  }
  for (int k = 0; k < 3; ++k) {
    out.push_back({std::string("initial.linear_velocity.") + axes[k], 1e-5 * fine,
                   [k](PhysicalParameters& p, double e) { p.linear_velocity[k] += e; },
                   [k](const ParameterGradient& g) { return g.linear_velocity[k]; }});
  }
  for (int k = 0; k < 3; ++k) {
    out.push_back({std::string("initial.angular_velocity.") + axes[k], (k == 1 ? 1e-5 : 1e-4) * fine,
                   [k](PhysicalParameters& p, double e) { p.angular_velocity[k] += e; },
                   [k](const ParameterGradient& g) { return g.angular_velocity[k]; }});
  }
  for (size_t k = 0; k < p0.region_youngs.size(); ++k)
    out.push_back({"material.regions[" + std::to_string(k) + "].youngs_modulus", 1e-5 * p0.region_youngs[k],
                   [k](PhysicalParameters& p, double e) { p.region_youngs[k] += e; },
                   [k](const ParameterGradient& g) { return g.input_entry("region_youngs", int(k)); }});
  if (p0.stiffness_gradient.norm() > 0)
    for (int k = 0; k < 3; ++k)
      out.push_back({std::string("material.stiffness_gradient.") + axes[k], 1e-5,
                     [k](PhysicalParameters& p, double e) { p.stiffness_gradient[k] += e; },
                     [k](const ParameterGradient& g) { return g.input_entry("stiffness_gradient", k); }});
  if (p0.air_drag > 0)
    out.push_back({"air_drag", 1e-5 * p0.air_drag, [](PhysicalParameters& p, double e) { p.air_drag += e; },
                   [](const ParameterGradient& g) { return g.input_entry("air_drag", 0); }});
  if (p0.planes.empty()) return out;
  out.push_back({"ground.height", 1e-6, [](PhysicalParameters& p, double e) { p.planes[0].height += e; },
                 [](const ParameterGradient& g) { return g.plane_height[0]; }});
  if (p0.planes[0].friction > 0)
    out.push_back({"ground.friction", 1e-6, [](PhysicalParameters& p, double e) { p.planes[0].friction += e; },
                   [](const ParameterGradient& g) { return g.input_entry("friction", 0); }});
  Vec3 t[2];
  tangents(p0.planes[0].normal.normalized(), &t[0], &t[1]);
  for (int k = 0; k < 2; ++k) {
    const Vec3 tk = t[k];
    // n(e) = normalize(n + e t): dn/de = t at e = 0, so dJ/de = (dJ/dn) . t.
    out.push_back({std::string("ground.normal.tangent") + std::to_string(k + 1), friction ? 1e-6 : 1e-5,
                   [tk](PhysicalParameters& p, double e) { p.planes[0].normal = (p.planes[0].normal.normalized() + e * tk).normalized(); },
                   [tk](const ParameterGradient& g) { return g.plane_normal[0].dot(tk); }});
  }
  return out;
}

std::vector<double> flatten(const CostGradient& r) {
  const ParameterGradient& g = r.gradient;
  std::vector<double> v = {r.cost, g.youngs_modulus, g.poisson_ratio, g.density, g.mass_damping, g.stiffness_damping};
  for (int k = 0; k < 3; ++k) v.push_back(g.gravity[k]);
  for (int k = 0; k < 3; ++k) v.push_back(g.linear_velocity[k]);
  for (int k = 0; k < 3; ++k) v.push_back(g.angular_velocity[k]);
  for (const Vec3& n : g.plane_normal)
    for (int k = 0; k < 3; ++k) v.push_back(n[k]);
  for (double h : g.plane_height) v.push_back(h);
  for (const auto& [name, values] : g.input)
    for (double x : values) v.push_back(x);
  return v;
}

bool bitwise_equal(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// ------------------------------------------------------------------------------------------

TEST(GradientPipeline, SceneHasCollisionsRotationAndObservations) {
  const Pipeline& pl = pipeline();
  Simulation sim(pl.scene, pl.grid, 1, true);
  double min_dist = 1e9;
  const Vec3 n = pl.params.planes[0].normal.normalized();
  for (int t = 1; t <= kSteps; ++t) {
    sim.step();
    for (const ContactPoint& cp : pl.grid.contact_points) {
      Vec3 x;
      for (int k = 0; k < 3; ++k) x[k] = cp.at(pl.grid.node_rest, k, sim.displacement(0));
      min_dist = std::min(min_dist, n.dot(x) - pl.params.planes[0].height);
    }
  }
  size_t matched = 0;
  const CostGradient r = evaluate_cost_gradient(sim, *pl.cost, pl.frames, {})[0];
  for (const FrameCost& f : r.frames) matched += f.matched;
  // The last frame's cotangents on active and on band nodes (the state is the last step's).
  std::vector<double> u_bar(3 * size_t(pl.grid.node_count), 0.0), band_bar(3 * size_t(pl.grid.band_count), 0.0);
  pl.cost->evaluate(pl.frames.back().points, 1.0, sim.displacement(0), sim.band_displacement(0), u_bar.data(),
                    band_bar.data());
  double nu = 0, nb = 0;
  for (double x : u_bar) nu += x * x;
  for (double x : band_bar) nb += x * x;
  std::printf("pipeline scene: %d cells, %d nodes, %d band nodes, %zu contact points, %zu observed points in %zu "
              "frames (%zu matched), deepest penetration %.4f m, cost %.6e, last frame |u_bar| %.3e |band_bar| %.3e\n",
              pl.grid.cell_count, pl.grid.node_count, pl.grid.band_count, pl.grid.contact_points.size(), pl.points,
              pl.frames.size(), matched, -min_dist, r.cost, std::sqrt(nu), std::sqrt(nb));
  EXPECT_GT(std::sqrt(nb), 0.01 * std::sqrt(nu)) << "the observations must reach cells with band corners";
  EXPECT_LT(min_dist, -0.005) << "the sphere must press into the ground";
  EXPECT_GT(pl.points, size_t(1000));
  EXPECT_GT(matched, pl.points * 9 / 10);
  EXPECT_GT(r.cost, 0.0);
}

// Runs a scope with a given OpenMP thread count and restores the previous one. The FD
// probes (about 70 forward runs) run on one thread: the engine's many small parallel
// regions (several per CG iteration) slow down 10-80x when the cores are shared with
// other processes (measured: this file 4 s with OMP_NUM_THREADS=1, 36 s with an active
// wait policy, up to 185 s at load 9 on 2 cores). Threading is what the checkpoint,
// batch and determinism tests exercise; they keep the default thread count.
class ScopedOmpThreads {
 public:
  explicit ScopedOmpThreads(int n) : saved_(omp_get_max_threads()) { omp_set_num_threads(n); }
  ~ScopedOmpThreads() { omp_set_num_threads(saved_); }

 private:
  int saved_;
};

// Adjoint vs central differences for every parameter of the scene; prints the table.
// step_scale: of the velocity and normal steps; step_factor: of every step.
void check_against_finite_differences(const Pipeline& pl, const char* label, double step_scale = 1.0,
                                      double step_factor = 1.0) {
  const ScopedOmpThreads single_thread(1);
  const auto t0 = std::chrono::steady_clock::now();
  Simulation sim(pl.scene, pl.grid, 1, true);
  sim.set_parameters(0, pl.params);
  const CostGradient r = evaluate_cost_gradient(sim, *pl.cost, pl.frames, {})[0];
  std::printf("%s: cost %.10e, gradient in %.2f s\n", label, r.cost, seconds_since(t0));
  std::printf("%-34s %12s %20s %20s %10s\n", "parameter", "FD step", "adjoint", "central FD", "rel error");
  double worst = 0;
  for (Probe pr : probes(pl.params, step_scale)) {
    pr.step *= step_factor;
    PhysicalParameters pp = pl.params, pm = pl.params;
    pr.perturb(pp, pr.step);
    pr.perturb(pm, -pr.step);
    const double fd = (cost_of(pl, sim, pp) - cost_of(pl, sim, pm)) / (2 * pr.step);
    const double adj = pr.adjoint(r.gradient);
    const double rel = std::abs(fd - adj) / std::max(std::abs(adj), 1e-300);
    worst = std::max(worst, rel);
    std::printf("%-34s %12.1e %20.12e %20.12e %10.2e\n", pr.name.c_str(), pr.step, adj, fd, rel);
    ::testing::Test::RecordProperty((std::string(label) + "_rel_error_" + pr.name).c_str(), std::to_string(rel));
    EXPECT_LE(rel, 1e-5) << label << " " << pr.name << ": adjoint " << adj << ", FD " << fd;
  }
  std::printf("%s: worst relative error %.2e; %.2f s in all\n", label, worst, seconds_since(t0));
}

// Progress of a long evaluation: one call per forward step, then one per backward step, the
// count rising to the total; without the gradient, the forward steps alone. The result is
// the one without the callback.
TEST(GradientPipeline, ReportsEveryStepOfBothPasses) {
  const Pipeline& pl = pipeline();
  for (bool gradient : {true, false}) {
    Simulation sim(pl.scene, pl.grid, 1, true);
    GradientOptions o;
    o.gradient = gradient;
    const double plain = evaluate_cost_gradient(sim, *pl.cost, pl.frames, o)[0].cost;
    std::vector<std::pair<int, int>> calls;
    o.on_step = [&](int done, int total) { calls.emplace_back(done, total); };
    const double reported = evaluate_cost_gradient(sim, *pl.cost, pl.frames, o)[0].cost;
    EXPECT_EQ(reported, plain);
    const int steps = pl.frames.back().step, total = gradient ? 2 * steps : steps;
    ASSERT_EQ(int(calls.size()), total) << gradient;
    for (size_t i = 0; i < calls.size(); ++i) {
      EXPECT_EQ(calls[i].second, total);
      EXPECT_EQ(calls[i].first, int(i) + 1) << "call " << i;
    }
  }
}

TEST(GradientPipeline, AdjointMatchesCentralDifferencesPerParameter) {
  // The initial velocity steps are a tenth: the cost has a kink within 1e-5 m/s of the
  // start's x velocity (the central difference's error there 6.1e-4, at a tenth 2.5e-9).
  check_against_finite_differences(pipeline(), "sphere on tilted ground", 0.1);
}

// The sphere with its grid in its own frame, turned (grid.frame "object"): the initial pose is a
// rigid displacement and the spin's arm turns with the body (models/sim/simulation.cpp reset,
// models/sim/gradient.cpp): every parameter's gradient, the initial spin's included.
TEST(GradientPipeline, PosedBodyAdjointMatchesCentralDifferencesPerParameter) {
  json j = pipeline_scene_json();
  j["object"]["rotation_deg"] = {20, -35, 50};
  j["grid"]["frame"] = "object";
  const std::unique_ptr<Pipeline> p = build_pipeline(j, Vec3(0.05, 0.3, -0.03), Vec3(1.3, 1.0, 1.5), Vec3(-1.7, 0.7, -0.6));
  ASSERT_NE(p->grid.pose.rotation, Eigen::Matrix3d::Identity());
  check_against_finite_differences(*p, "turned sphere, grid in its own frame", 0.1);
}

// The sphere observed at every third step only: the steps between run without the band
// extension (models/sim/gradient.cpp), forward and adjoint.
const Pipeline& sparse_pipeline() {
  static const std::unique_ptr<Pipeline> p = [] {
    std::unique_ptr<Pipeline> q =
        build_pipeline(pipeline_scene_json(), Vec3(0.05, 0.3, -0.03), Vec3(1.3, 1.0, 1.5), Vec3(-1.7, 0.7, -0.6));
    std::vector<ObservedFrame> kept;
    for (ObservedFrame& f : q->frames)
      if (f.step % 3 == 0) kept.push_back(std::move(f));
    q->frames = std::move(kept);
    return q;
  }();
  return *p;
}

TEST(GradientPipeline, SparseFramesAdjointMatchesCentralDifferencesPerParameter) {
  check_against_finite_differences(sparse_pipeline(), "sphere observed every third step");
}

// Each observed frame's cost is the one of a run that extends the band at every step, and a
// step without the extension leaves no band to read.
TEST(GradientPipeline, StepsWithoutExtensionChangeNoObservedCost) {
  const Pipeline& pl = sparse_pipeline();
  ASSERT_EQ(pl.frames.size(), size_t(kSteps / 3));
  Simulation sim(pl.scene, pl.grid, 1, true);
  GradientOptions forward;
  forward.gradient = false;
  const CostGradient sparse = evaluate_cost_gradient(sim, *pl.cost, pl.frames, forward)[0];
  Simulation every(pl.scene, pl.grid, 1, true);
  for (size_t f = 0; f < pl.frames.size(); ++f) {
    while (every.steps_taken() < pl.frames[f].step) every.step();
    const FrameCost c = pl.cost->evaluate(pl.frames[f].points, pl.frames[f].weight, every.displacement(0),
                                          every.band_displacement(0), nullptr, nullptr);
    EXPECT_GT(c.cost, 0);
    EXPECT_NEAR(sparse.frames[f].cost, c.cost, 1e-12 * c.cost) << "frame at step " << pl.frames[f].step;
  }
  every.step(true, false);
  EXPECT_THROW(every.band_displacement(0), std::logic_error);
  every.step();
  EXPECT_NO_THROW(every.band_displacement(0));
}

TEST(GradientPipeline, FrictionAdjointMatchesCentralDifferencesPerParameter) {
  check_against_finite_differences(friction_pipeline(), "sphere sliding with friction");
}

// Data made with mu = 0.15 and every other parameter known: d cost / d mu must point to 0.15
// from both sides (a sweep's sign test). At 0.15 the sphere slides through its contact; from
// about 0.4 on it rolls without slipping after the bounce and the cost hardly depends on mu.
TEST(GradientPipeline, FrictionGradientPointsToTheTrueCoefficient) {
  json j = pipeline_scene_json();
  j["ground"]["friction"] = 0.15;
  const auto pl = build_pipeline(j, Vec3(0.05, 0.3, -0.03), Vec3(1.3, 1.0, 1.5), Vec3(-1.7, 0.7, -0.6),
                                 [](PhysicalParameters&) {});
  Simulation sim(pl->scene, pl->grid, 1, true);
  std::printf("%8s %14s %14s\n", "mu", "cost", "d cost / d mu");
  // The depth noise moves the cost's minimum a little (measured between 0.17 and 0.2): the
  // signs are required outside [0.1, 0.22].
  for (double mu : {0.0, 0.05, 0.1, 0.13, 0.17, 0.2, 0.22, 0.25, 0.3}) {
    PhysicalParameters p = pl->params;
    p.planes[0].friction = mu;
    sim.set_parameters(0, p);
    const CostGradient r = evaluate_cost_gradient(sim, *pl->cost, pl->frames, {})[0];
    std::printf("%8.2f %14.6e %14.6e\n", mu, r.cost, r.gradient.input_entry("friction", 0));
    if (mu <= 0.1) {
      EXPECT_LT(r.gradient.input_entry("friction", 0), 0) << "mu " << mu;
    }
    if (mu >= 0.22) {
      EXPECT_GT(r.gradient.input_entry("friction", 0), 0) << "mu " << mu;
    }
  }
}

TEST(GradientPipeline, HeterogeneousStiffnessAndAirDragAdjointMatchesCentralDifferencesPerParameter) {
  const Pipeline& pl = heterogeneous_pipeline();
  // Cells with a share of no region, of region 0 and of region 1 (a split cell counts in each).
  int in_region[3] = {0, 0, 0};
  for (int e = 0; e < pl.grid.cell_count; ++e) {
    const double s0 = pl.grid.cell_region_share[2 * size_t(e)], s1 = pl.grid.cell_region_share[2 * size_t(e) + 1];
    in_region[0] += s0 + s1 < 1, in_region[1] += s0 > 0, in_region[2] += s1 > 0;
  }
  std::printf("heterogeneous sphere: %d cells, %d with a share of no region, %d of region 0, %d of region 1\n",
              pl.grid.cell_count, in_region[0], in_region[1], in_region[2]);
  for (int n : in_region) ASSERT_GT(n, 0);
  check_against_finite_differences(pl, "heterogeneous sphere with air drag", 0.1);
}

TEST(GradientPipeline, ImplicitContactAndUpdatedRotationAdjointMatchesCentralDifferences) {
  // At the default steps a probe of the ground's height (1e-6 m) or the damping moves one of
  // the stiff ground's contact points across a kink: measured 4.3e-5 there, 1.4e-10 at a tenth.
  check_against_finite_differences(iterating_pipeline(), "sphere, implicit contact, updated rotation", 0.1, 0.1);
}

TEST(GradientPipeline, LineSearchedContactAdjointMatchesCentralDifferences) {
  const Pipeline& pl = line_search_pipeline();
  Simulation sim(pl.scene, pl.grid, 1, true);
  sim.set_parameters(0, pl.params);
  const Graph& g = sim.timestep_graph().graph;
  int scaled = 0, iterations = 0;
  for (int n = 0; n < kSteps; ++n) {
    sim.step();
    for (int k = 0; k < pl.scene.solver.nonlinear_iterations; ++k) {
      const std::string name = k == 0 ? "line_search_sums" : "line_search_sums_it" + std::to_string(k);
      const std::vector<double>& sums = sim.interpreter().store().all(g.find_tensor(name));
      scaled += ops::line_search_alpha(sums.data(), pl.scene.time.dt) < 1;
      ++iterations;
    }
  }
  std::printf("line search: %d of %d iterations scaled back\n", scaled, iterations);
  ASSERT_GT(scaled, 0) << "the line search never acted: the test could not fail for it";
  // Every step a tenth: at the default steps a probe crosses a kink (worst 3.7e-3; 9.0e-7 at
  // a tenth).
  check_against_finite_differences(pl, "sphere, line-searched contact", 0.1, 0.1);
}

// The adjoint time-step solves of one step share a residual reference, the largest
// cotangent among them (runtime/solvers.cpp): once a step's nonlinear iterations have
// converged, the earlier iterations' solves get cotangents many orders smaller than the
// last one's and stop at once. Against the same step's adjoint with every solve to its own
// relative residual (the ops' adjoints one at a time, run_op_adjoint): the cotangents agree
// to the solves' tolerance, and the CG iterations of the steps in flight (the first three,
// whose iterations converge at once) fall to a third; in contact on this sharp ground the
// iterations are still converging, and their solves have work to do.
TEST(GradientPipeline, ConvergedIterationsAdjointSolvesStopAtOnce) {
  const Pipeline& pl = line_search_pipeline();
  Simulation sim(pl.scene, pl.grid, 1, true);
  sim.set_parameters(0, pl.params);
  const TimestepGraph& tg = sim.timestep_graph();
  Interpreter<double>& in = sim.interpreter();
  TensorStore<double>& adj = in.adjoint();
  const int ops = int(tg.graph.ops().size());
  double worst = 0;
  for (int n = 0; n < kSteps; ++n) {
    sim.step();
    std::vector<std::vector<double>> result[2];
    long iterations[2] = {0, 0};
    for (int mode = 0; mode < 2; ++mode) {
      in.clear_adjoints(true);
      std::mt19937_64 rng(31 + n);
      std::normal_distribution<double> normal(0.0, 1.0);
      for (int t : {tg.u, tg.v, tg.band_u})
        for (double& x : adj.all(t)) x = normal(rng);
      if (mode == 0) {
        in.run_adjoint();
        iterations[0] = in.report().adjoint_cg_iterations[0];
      } else {
        for (int o = ops - 1; o >= 0; --o) {
          in.run_op_adjoint(o);
          iterations[1] += in.report().adjoint_cg_iterations[0];
        }
      }
      for (size_t t = 0; t < tg.graph.tensors().size(); ++t)
        if (tg.graph.tensor(int(t)).role != TensorInfo::Role::Intermediate) result[mode].push_back(adj.all(int(t)));
    }
    for (size_t k = 0; k < result[0].size(); ++k) {
      double diff = 0, size = 0;
      for (size_t i = 0; i < result[0][k].size(); ++i) {
        diff = std::max(diff, std::abs(result[0][k][i] - result[1][k][i]));
        size = std::max(size, std::abs(result[1][k][i]));
      }
      if (size > 0) worst = std::max(worst, diff / size);
    }
    std::printf("step %2d: adjoint CG iterations %3ld with the shared reference, %3ld with each solve relative\n",
                n + 1, iterations[0], iterations[1]);
    EXPECT_LE(iterations[0], iterations[1]) << "step " << n + 1;
    if (n < 3) {
      EXPECT_LT(2 * iterations[0], iterations[1]) << "step " << n + 1 << " (in flight)";
    }
  }
  std::printf("largest relative difference of a cotangent: %.2e\n", worst);
  EXPECT_LT(worst, 1e-9);
}

TEST(GradientPipeline, NeoHookeanAdjointMatchesCentralDifferences) {
  check_against_finite_differences(neo_hookean_pipeline(), "Neo-Hookean sphere, implicit contact", 0.1);
}

TEST(GradientPipeline, ClampedBarAdjointMatchesCentralDifferences) {
  const Pipeline& pl = clamped_bar();
  Simulation sim(pl.scene, pl.grid, 1, true);
  int fixed = 0;
  for (char f : sim.fixed_nodes()) fixed += f;
  std::printf("clamped bar: %d cells, %d nodes (%d fixed), %d band nodes, %zu observed points\n", pl.grid.cell_count,
              pl.grid.node_count, fixed, pl.grid.band_count, pl.points);
  ASSERT_GT(fixed, 0);
  ASSERT_LT(fixed, pl.grid.node_count / 2);
  check_against_finite_differences(pl, "clamped bar");
}

TEST(GradientPipeline, CheckpointingGivesTheSameGradient) {
  const Pipeline& pl = pipeline();
  Simulation sim(pl.scene, pl.grid, 1, true);
  GradientOptions every, third, whole;
  every.checkpoint_every = 1;
  third.checkpoint_every = 3;
  whole.memory_budget_bytes = 1e9;
  ASSERT_LE(double(pl.frames.back().step) * double(sim.step_bytes()), whole.memory_budget_bytes);  // steps kept whole
  const std::vector<double> a = flatten(evaluate_cost_gradient(sim, *pl.cost, pl.frames, every)[0]);
  const std::vector<double> b = flatten(evaluate_cost_gradient(sim, *pl.cost, pl.frames, third)[0]);
  const std::vector<double> c = flatten(evaluate_cost_gradient(sim, *pl.cost, pl.frames, whole)[0]);
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]) / std::max(std::abs(a[i]), 1e-300));
  std::printf("checkpoint_every 3 vs every state stored: worst relative difference %.2e (bitwise equal: %s); "
              "steps kept whole vs every state stored: bitwise equal: %s\n",
              worst, bitwise_equal(a, b) ? "yes" : "no", bitwise_equal(a, c) ? "yes" : "no");
  EXPECT_LE(worst, 1e-12);
  EXPECT_TRUE(bitwise_equal(a, c));
}

// The torus (802 cells: its cell loops run in parallel) gives the same bits on one thread and
// on two, forward and adjoint: every parallel loop writes only its own entries and every
// sum has a fixed order.
TEST(GradientPipeline, ThreadCountDoesNotChangeTheBits) {
  const Scene scene = load_scene(std::string(SSC_SOURCE_DIR) + "/examples/torus.json");
  const SimGrid grid = build_body_grid(scene);
  const FrameCostFunction cost = synthetic_frame_cost(grid);
  std::vector<double> gradient[2], state[2];
  for (int run = 0; run < 2; ++run) {
    const ScopedOmpThreads threads(run == 0 ? 1 : 2);
    Simulation sim(scene, grid, 1, true);
    gradient[run] = flatten(evaluate_trajectory_gradient(sim, {6, 12}, cost, {})[0]);
    for (int s = 0; s < 12; ++s) sim.step();
    state[run].assign(sim.displacement(0), sim.displacement(0) + 3 * grid.node_count);
  }
  EXPECT_TRUE(bitwise_equal(state[0], state[1]));
  EXPECT_TRUE(bitwise_equal(gradient[0], gradient[1]));
}

TEST(GradientPipeline, BatchOfTwoEqualsTwoSingleRunsBitwise) {
  const Pipeline& pl = pipeline();
  PhysicalParameters p0 = pl.params, p1 = pl.params;
  p1.youngs_modulus = 3.1e4;
  p1.poisson_ratio = 0.38;
  p1.density = 140;
  p1.mass_damping = 0.05;
  p1.stiffness_damping = 0.02;
  p1.gravity = Vec3(0.3, -9.0, -0.2);
  p1.linear_velocity = Vec3(-0.2, -1.0, 0.5);
  p1.angular_velocity = Vec3(-1.0, 2.5, 0.5);
  p1.planes[0].height = -0.01;
  p1.planes[0].normal = Vec3(-0.1, 1.0, 0.12).normalized();
  Simulation batch(pl.scene, pl.grid, 2, true);
  batch.set_parameters(0, p0);
  batch.set_parameters(1, p1);
  const std::vector<CostGradient> rb = evaluate_cost_gradient(batch, *pl.cost, pl.frames, {});
  ASSERT_EQ(rb.size(), 2u);
  Simulation single(pl.scene, pl.grid, 1, true);
  single.set_parameters(0, p0);
  const std::vector<double> s0 = flatten(evaluate_cost_gradient(single, *pl.cost, pl.frames, {})[0]);
  single.set_parameters(0, p1);
  const std::vector<double> s1 = flatten(evaluate_cost_gradient(single, *pl.cost, pl.frames, {})[0]);
  EXPECT_TRUE(bitwise_equal(flatten(rb[0]), s0)) << "batch item 0";
  EXPECT_TRUE(bitwise_equal(flatten(rb[1]), s1)) << "batch item 1";
  EXPECT_FALSE(bitwise_equal(s0, s1)) << "the two parameter sets must differ";
}

TEST(GradientPipeline, RepeatedRunsAreBitwiseIdentical) {
  const Pipeline& pl = pipeline();
  Simulation sim(pl.scene, pl.grid, 1, true);
  const std::vector<double> a = flatten(evaluate_cost_gradient(sim, *pl.cost, pl.frames, {})[0]);
  const std::vector<double> b = flatten(evaluate_cost_gradient(sim, *pl.cost, pl.frames, {})[0]);
  Simulation fresh(pl.scene, pl.grid, 1, true);
  const std::vector<double> c = flatten(evaluate_cost_gradient(fresh, *pl.cost, pl.frames, {})[0]);
  EXPECT_TRUE(bitwise_equal(a, b)) << "same simulation object, run twice";
  EXPECT_TRUE(bitwise_equal(a, c)) << "a fresh simulation object";
}

// A start of a reconstruction can diverge before the simulation's checks stop it: the cost
// must stay finite and bounded in memory when the deformed cells spread over kilometres
// (its search grid once asked for 4096^3 bins here).
TEST(GradientPipeline, CostOfFarSpreadCellsStaysBounded) {
  const Pipeline& pl = pipeline();
  const SimGrid& g = pl.grid;
  std::vector<double> u(3 * size_t(g.node_count), 0.0), band(3 * size_t(g.band_count), 0.0);
  u[0] = 5e3;
  u[4] = -7e3;
  band[5] = 9e3;
  std::vector<double> ub(u.size(), 0.0), bb(band.size(), 0.0);
  FrameCost c;
  ASSERT_NO_THROW(c = pl.cost->evaluate(pl.frames.back().points, 1.0, u.data(), band.data(), ub.data(), bb.data()));
  EXPECT_TRUE(std::isfinite(c.cost));
  EXPECT_GT(c.matched, 0);  // the cells left in place still match points
}

}  // namespace
}  // namespace ssc
