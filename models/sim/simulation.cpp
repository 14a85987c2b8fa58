// Forward simulation driver (see simulation.h).
#include "models/sim/simulation.h"

#include "models/sim/contact_potential.h"
#include "models/sim/parameter_table.h"
#include "models/sim/resting_start.h"
#include "models/io/run_record.h"

#include <fmt/format.h>

#include <omp.h>

#include <cmath>

#include "runtime/errors.h"
#include "ops/elasticity.h"
#include "ops/gather.h"
#include "ops/neo_hookean.h"
#include "ops/polar.h"
#include "ops/stiffness_field.h"
#include "runtime/batch_loop.h"
#include "runtime/cuda_runtime.h"
#include "runtime/interpreter_backend.h"
#include "runtime/pcg.h"

namespace ssc {

PhysicalParameters PhysicalParameters::from_scene(const Scene& s) {
  PhysicalParameters p;
  p.youngs_modulus = s.material.youngs_modulus;
  p.poisson_ratio = s.material.poisson_ratio;
  p.density = s.material.density;
  p.mass_damping = s.material.mass_damping;
  p.stiffness_damping = s.material.stiffness_damping;
  p.gravity = s.gravity;
  p.linear_velocity = s.linear_velocity;
  p.angular_velocity = s.angular_velocity;
  p.planes = s.planes;
  for (const MaterialRegion& r : s.material.regions) p.region_youngs.push_back(r.youngs_modulus);
  p.stiffness_gradient = s.material.stiffness_gradient;
  p.air_drag = s.air_drag;
  return p;
}

Simulation::Simulation(const Scene& scene, const SimGrid& grid, int batch, bool extension)
    : grid_(grid),
      graph_(build_timestep_graph(int(scene.planes.size()), extension, timestep_model(scene))),
      params_(batch, PhysicalParameters::from_scene(scene)),
      audits_(batch),
      dt_(scene.time.dt),
      theta_(scene.time.theta) {
  SolverOptions options;
  options.cg_tolerance = scene.solver.tolerance;
  options.cg_max_iterations = scene.solver.max_iterations;
  options.extension_tolerance = scene.solver.extension_tolerance;
  interpreter_ = std::make_unique<Interpreter<double>>(graph_.graph, grid_, batch, options);
  backend_ = std::make_unique<InterpreterBackend>(*interpreter_);
  fixed_.assign(grid.node_count, 0);
  for (int i = 0; i < grid.node_count; ++i) {
    const Eigen::Vector3d x = grid.node_start(i);
    for (const DirichletBox& box : scene.dirichlet)
      if ((x.array() >= box.min.array()).all() && (x.array() <= box.max.array()).all()) fixed_[i] = 1;
  }
  for (SimulationAudit& a : audits_) a.tolerance = scene.solver.energy_tolerance;
  pose_band_offset();
  if (const std::string inside = initial_penetration(grid, params_[0]); !inside.empty()) throw InputError(scene.file + ": " + inside);
  for (const RestingStart& r : resting_start_jumps(grid, params_[0], fixed_))
    warn("resting_start", scene.file + ": " + resting_start_message(r, params_[0]));
  reset();
}

Simulation::~Simulation() = default;

void Simulation::use_gpu(const std::string& real, int ordinal) {
  GpuOptions options;
  options.real = real;
  options.ordinal = ordinal;
  sync_host();
  backend_ = std::make_unique<GpuTimestep>(graph_.graph, grid_, batch(), interpreter_->options(), options);
  gpu_ = static_cast<GpuTimestep*>(backend_.get());
  device_current_ = false;
  kept_.clear();  // the old backend's snapshots went with it
}

int Simulation::degenerate_cells(int b) const {
  const int t = graph_.graph.find_tensor("polar_status");
  const double* status = interpreter_->store().data(t, b);
  int n = 0;
  for (int e = 0; e < grid_.cell_count; ++e) n += status[e] == double(ops::kPolarDegenerate);
  return n;
}

int Simulation::last_cg_iterations(int b) const { return backend_->cg_iterations().at(b); }

void Simulation::set_parameters(int b, const PhysicalParameters& p) {
  if (p.planes.size() != params_[b].planes.size())
    throw std::logic_error("the number of ground planes is part of the graph and cannot change");
  if (p.region_youngs.size() != params_[b].region_youngs.size())
    throw std::logic_error("the number of material regions is part of the graph and cannot change");
  if (const std::string inside = initial_penetration(grid_, p); !inside.empty())
    throw SimulationError("step 0: " + inside, {b});
  params_[b] = p;
  reset();
}

void Simulation::write_inputs(int b) {
  TensorStore<double>& st = interpreter_->store();
  const PhysicalParameters& p = params_[b];
  st.data(graph_.youngs_modulus, b)[0] = p.youngs_modulus;
  st.data(graph_.poisson_ratio, b)[0] = p.poisson_ratio;
  st.data(graph_.density, b)[0] = p.density;
  st.data(graph_.mass_damping, b)[0] = p.mass_damping;
  st.data(graph_.stiffness_damping, b)[0] = p.stiffness_damping;
  for (int k = 0; k < 3; ++k) st.data(graph_.gravity, b)[k] = p.gravity[k];
  st.data(graph_.dt, b)[0] = dt_;
  st.data(graph_.theta, b)[0] = theta_;
  if (graph_.ground_planes >= 0) {
    double* q = st.data(graph_.ground_planes, b);
    for (size_t i = 0; i < p.planes.size(); ++i) {
      const PlaneSpec& pl = p.planes[i];
      const Eigen::Vector3d n = pl.normal.normalized();
      const double v[6] = {n.x(), n.y(), n.z(), pl.height, pl.stiffness, pl.softmin_alpha};
      for (int k = 0; k < 6; ++k) q[6 * i + k] = v[k];
    }
  }
  // Parameters that feed a graph input entry as they are (parameter_table.h).
  for (const ParameterRow& row : parameter_table(p)) {
    if (row.graph_component < 0) continue;
    const int t = graph_.graph.find_tensor(row.graph_input);
    if (t >= 0) st.data(t, b)[row.graph_component] = row.get(p);
  }
  double* fixed = st.data(graph_.fixed, b);
  for (int i = 0; i < grid_.node_count; ++i) fixed[i] = fixed_[i];
}

double Simulation::total_mass() const {
  double m = 0;
  for (double v : grid_.node_volume) m += v;
  return m * params_[0].density;
}

// The band extension (the Laplacian's, ops/extension.h) carries a translation exactly but not a
// rotation, so an initial pose's rigid displacement f would bend the band cells from the first
// extended step on. The band takes f plus the extension of what the body did since instead:
// f_band + Ext(u - f_active) = Ext(u) + (f_band - Ext(f_active)), the engine's extension plus a
// constant offset, formed here once by extending f_active.
void Simulation::pose_band_offset() {
  const RestPose& pose = grid_.pose;
  if (graph_.extension_op < 0 || (pose.rotation == Eigen::Matrix3d::Identity() && pose.translation.isZero())) return;
  TensorStore<double>& st = interpreter_->store();
  std::vector<double> rigid_band(3 * size_t(grid_.band_count));
  for (int j = 0; j < grid_.band_count; ++j) {
    const Eigen::Vector3d x = grid_.sdf.node_position(grid_.band_grid[size_t(j)]);
    const Eigen::Vector3d f = pose.start(x) - x;
    for (int k = 0; k < 3; ++k) rigid_band[3 * size_t(j) + k] = f[k];
  }
  double* u = st.data(graph_.u, 0);
  for (int i = 0; i < grid_.node_count; ++i) {
    const Eigen::Vector3d x(grid_.node_rest[3 * i], grid_.node_rest[3 * i + 1], grid_.node_rest[3 * i + 2]);
    const Eigen::Vector3d f = pose.start(x) - x;
    for (int k = 0; k < 3; ++k) u[3 * i + k] = f[k];
  }
  std::copy(rigid_band.begin(), rigid_band.end(), st.data(graph_.band_guess, 0));
  interpreter_->run_op(graph_.extension_op);
  const double* extended = st.data(graph_.band_u, 0);
  band_pose_offset_.resize(rigid_band.size());
  for (size_t k = 0; k < rigid_band.size(); ++k) band_pose_offset_[k] = rigid_band[k] - extended[k];
  band_posed_.assign(size_t(batch()), std::vector<double>(rigid_band.size()));
}

void Simulation::reset() {
  device_current_ = false;
  host_stale_ = false;
  TensorStore<double>& st = interpreter_->store();
  for (int b = 0; b < batch(); ++b) {
    write_inputs(b);
    // Centre of mass with the lumped node volumes, so that the spin carries no momentum.
    Eigen::Vector3d com = Eigen::Vector3d::Zero();
    double vol = 0;
    for (int i = 0; i < grid_.node_count; ++i) {
      com += grid_.node_volume[i] * Eigen::Vector3d(grid_.node_rest[3 * i], grid_.node_rest[3 * i + 1], grid_.node_rest[3 * i + 2]);
      vol += grid_.node_volume[i];
    }
    com /= vol;
    spin_center_ = com;
    double* u = st.data(graph_.u_prev, b);
    double* v = st.data(graph_.v_prev, b);
    const PhysicalParameters& p = params_[b];
    // The initial pose is a rigid displacement; the spin is about the centre of mass as posed.
    // (com is in the rest frame; the spin's arm is rotated with the body.)
    const RestPose& pose = grid_.pose;
    for (int i = 0; i < grid_.node_count; ++i) {
      const Eigen::Vector3d x(grid_.node_rest[3 * i], grid_.node_rest[3 * i + 1], grid_.node_rest[3 * i + 2]);
      const Eigen::Vector3d u0 = pose.start(x) - x;
      const Eigen::Vector3d vel =
          fixed_[i] ? Eigen::Vector3d::Zero() : Eigen::Vector3d(p.linear_velocity + p.angular_velocity.cross(pose.rotation * (x - com)));
      for (int k = 0; k < 3; ++k) {
        u[3 * i + k] = u0[k];
        v[3 * i + k] = vel[k];
      }
    }
    // The band starts with the body's rigid displacement: what the engine holds is that minus
    // the pose's offset (band_displacement adds it back).
    for (int t : {graph_.band_guess, graph_.band_u}) {
      if (t < 0) continue;
      double* band = st.data(t, b);
      for (int j = 0; j < grid_.band_count; ++j) {
        const Eigen::Vector3d x = grid_.sdf.node_position(grid_.band_grid[size_t(j)]);
        const Eigen::Vector3d u0 = pose.start(x) - x;
        for (int k = 0; k < 3; ++k)
          band[3 * j + k] = u0[k] - (band_pose_offset_.empty() ? 0.0 : band_pose_offset_[3 * size_t(j) + k]);
      }
    }
    if (graph_.v_before >= 0) std::copy_n(v, 3 * grid_.node_count, st.data(graph_.v_before, b));  // no acceleration yet
  }
  steps_ = 0;
  band_current_ = true;
  for (int b = 0; b < batch(); ++b) audits_[b].start(*this, b);
}

void Simulation::check_state(int b, const char* when) {
  const double* u = displacement(b);
  for (int i = 0; i < 3 * grid_.node_count; ++i)
    if (!std::isfinite(u[i]))
      throw SimulationError(fmt::format("{} {}: the simulation produced a non-finite displacement (batch item {}); "
                                        "lower time.dt or the ground stiffness",
                                        when, steps_, b),
                            {b});
  audits_[b].check(*this, b, steps_, when);
}

// Items in parallel when there are enough of them to fill the threads; else one after the
// other, each with its parallel loop over the cells. Every item is checked: the error is the
// first failing item's, naming all failing items.
void Simulation::check_states(const char* when) {
  std::vector<std::string> errors(batch());
  auto check = [&](int b) {
    try {
      check_state(b, when);
    } catch (const SimulationError& e) {
      errors[b] = e.what();
    }
  };
  if (batch() >= omp_get_max_threads())
    for_each_batch_item(batch(), check);
  else
    for (int b = 0; b < batch(); ++b) check(b);
  std::vector<int> failed;
  for (int b = 0; b < batch(); ++b)
    if (!errors[b].empty()) failed.push_back(b);
  if (failed.empty()) return;
  std::string message = errors[failed[0]];
  if (failed.size() > 1) message += fmt::format(" ({} batch items failed here)", failed.size());
  throw SimulationError(message, failed);
}

void Simulation::step(bool to_host, bool extend) { advance(to_host, -1, extend); }

void Simulation::step_and_keep(int key, bool extend) { advance(false, key, extend); }

void Simulation::run_step(bool extend) {
  if (extend || graph_.extension_op < 0)
    backend_->run();
  else
    backend_->run_prefix(graph_.extension_op);
}

void Simulation::advance(bool to_host, int keep_key, bool extend) {
  TensorStore<double>& st = interpreter_->store();
  const bool band = graph_.band_u >= 0 && extend;
  try {
    if (!device_current_) backend_->upload(st);
    device_current_ = false;
    run_step(extend);
    band_current_ = graph_.band_u < 0 || extend;
    if (keep_key >= 0) keep(keep_key, step_tensors(), steps_);
    if (to_host)
      for (int t : {graph_.u, graph_.v, band ? graph_.band_u : -1, graph_.cg_iterations})
        if (t >= 0) backend_->download(st, t);
    std::vector<std::pair<int, int>> next;  // in order: v_prev becomes v_before before v becomes v_prev
    if (graph_.v_before >= 0) next.push_back({graph_.v_prev, graph_.v_before});
    next.insert(next.end(), {{graph_.u, graph_.u_prev}, {graph_.v, graph_.v_prev}});
    if (band) next.push_back({graph_.band_u, graph_.band_guess});
    backend_->copy_tensors(next);
    if (to_host && graph_.v_before >= 0) backend_->download(st, graph_.v_before);  // not derived on the host below
    device_current_ = true;
  } catch (const SimulationError& e) {
    throw SimulationError(fmt::format("step {}: {}", steps_ + 1, e.what()), e.items);
  }
  ++steps_;
  if (!to_host) {
    host_stale_ = true;
    return;
  }
  host_stale_ = false;
  for (int b = 0; b < batch(); ++b) {
    std::copy_n(st.data(graph_.u, b), 3 * grid_.node_count, st.data(graph_.u_prev, b));
    std::copy_n(st.data(graph_.v, b), 3 * grid_.node_count, st.data(graph_.v_prev, b));
    if (band) std::copy_n(st.data(graph_.band_u, b), 3 * grid_.band_count, st.data(graph_.band_guess, b));
  }
  check_states("step");
}

void Simulation::sync_host() {
  if (!host_stale_) return;
  TensorStore<double>& st = interpreter_->store();
  for (int t : state_tensors()) backend_->download(st, t);
  host_stale_ = false;
  check_states("by step");  // the steps since the last sync ran unchecked
}

std::vector<int> Simulation::state_tensors() const {
  std::vector<int> t = {graph_.u_prev, graph_.v_prev};
  if (graph_.band_guess >= 0) t.push_back(graph_.band_guess);
  if (graph_.v_before >= 0) t.push_back(graph_.v_before);
  return t;
}

std::vector<int> Simulation::step_tensors() const {
  std::vector<int> t;
  for (size_t i = 0; i < graph_.graph.tensors().size(); ++i)
    if (graph_.graph.tensor(int(i)).role != TensorInfo::Role::Input) t.push_back(int(i));
  return t;
}

size_t Simulation::step_bytes() const {
  size_t bytes = 0;
  for (int t : step_tensors()) bytes += interpreter_->store().all(t).size() * sizeof(double);
  return bytes;
}

// The backend must hold the host's state (device_current_) when this runs.
void Simulation::keep(int key, const std::vector<int>& tensors, int step) {
  Kept& k = kept_[key];
  k.step = step;
  k.tensors = tensors;
  k.band_current = band_current_;
  backend_->save_snapshot(key, tensors);
}

void Simulation::restore(int key) {
  const auto it = kept_.find(key);
  if (it == kept_.end()) throw std::logic_error("Simulation: no checkpoint or kept step under this key");
  const Kept& k = it->second;
  if (!device_current_) backend_->upload(interpreter_->store());  // the inputs
  backend_->load_snapshot(key, k.tensors);
  device_current_ = true;
  host_stale_ = true;
  steps_ = k.step;
  band_current_ = k.band_current;
}

void Simulation::save_checkpoint(int key) {
  if (!device_current_) {
    backend_->upload(interpreter_->store());
    device_current_ = true;
  }
  keep(key, state_tensors(), steps_);
}

void Simulation::load_checkpoint(int key) { restore(key); }

void Simulation::load_step(int key) { restore(key); }

void Simulation::drop_checkpoint(int key) {
  kept_.erase(key);
  backend_->drop_snapshot(key);
}

void Simulation::clear_checkpoints() {
  for (const auto& [key, k] : kept_) backend_->drop_snapshot(key);
  kept_.clear();
}

void Simulation::recompute_step(bool extend) {
  if (!device_current_) backend_->upload(interpreter_->store());
  device_current_ = true;
  run_step(extend);
}

Simulation::State Simulation::state(int b) const {
  State s;
  require_host_state();
  const double *u = displacement(b), *v = velocity(b);
  const double* band = graph_.band_u >= 0 ? interpreter_->store().data(graph_.band_guess, b) : nullptr;
  s.u.assign(u, u + 3 * grid_.node_count);
  s.v.assign(v, v + 3 * grid_.node_count);
  if (band) s.band.assign(band, band + 3 * grid_.band_count);
  if (graph_.v_before >= 0) {
    const double* before = interpreter_->store().data(graph_.v_before, b);
    s.v_before.assign(before, before + 3 * grid_.node_count);
  }
  return s;
}

void Simulation::set_state(int b, const State& s, int step) {
  sync_host();  // the other items' state
  device_current_ = false;
  TensorStore<double>& st = interpreter_->store();
  std::copy(s.u.begin(), s.u.end(), st.data(graph_.u_prev, b));
  std::copy(s.v.begin(), s.v.end(), st.data(graph_.v_prev, b));
  if (graph_.band_guess >= 0) {
    if (s.band.empty())
      std::fill_n(st.data(graph_.band_guess, b), 3 * grid_.band_count, 0.0);
    else
      std::copy(s.band.begin(), s.band.end(), st.data(graph_.band_guess, b));
  }
  if (graph_.v_before >= 0) {
    const std::vector<double>& before = s.v_before.empty() ? s.v : s.v_before;  // none: no acceleration carried on
    std::copy(before.begin(), before.end(), st.data(graph_.v_before, b));
  }
  steps_ = step;
  band_current_ = true;
}

void Simulation::require_host_state() const {
  if (host_stale_) throw std::logic_error("Simulation: the state is on the device; call sync_host() first");
}

const double* Simulation::displacement(int b) const {
  require_host_state();
  return interpreter_->store().data(graph_.u_prev, b);
}
const double* Simulation::velocity(int b) const {
  require_host_state();
  return interpreter_->store().data(graph_.v_prev, b);
}
const double* Simulation::band_displacement(int b) const {
  require_host_state();
  if (!band_current_) throw std::logic_error("Simulation: the last step ran without the band extension");
  if (graph_.band_u < 0) return nullptr;
  const double* band = interpreter_->store().data(graph_.band_guess, b);
  if (band_pose_offset_.empty()) return band;
  std::vector<double>& posed = band_posed_[size_t(b)];
  for (size_t k = 0; k < posed.size(); ++k) posed[k] = band[k] + band_pose_offset_[k];
  return posed.data();
}

Eigen::Vector3d Simulation::center_of_mass(int b) const {
  const double* u = displacement(b);
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  double m = 0;
  for (int i = 0; i < grid_.node_count; ++i) {
    const double w = grid_.node_volume[i];
    for (int k = 0; k < 3; ++k) s[k] += w * (grid_.node_rest[3 * i + k] + u[3 * i + k]);
    m += w;
  }
  return s / m;
}

Eigen::Vector3d Simulation::linear_momentum(int b) const {
  const double* v = velocity(b);
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  for (int i = 0; i < grid_.node_count; ++i)
    for (int k = 0; k < 3; ++k) s[k] += grid_.node_volume[i] * v[3 * i + k];
  return s * params_[b].density;
}

Eigen::Vector3d Simulation::angular_momentum(int b) const {
  const double *u = displacement(b), *v = velocity(b);
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  for (int i = 0; i < grid_.node_count; ++i) {
    const Eigen::Vector3d x(grid_.node_rest[3 * i] + u[3 * i], grid_.node_rest[3 * i + 1] + u[3 * i + 1],
                            grid_.node_rest[3 * i + 2] + u[3 * i + 2]);
    s += grid_.node_volume[i] * x.cross(Eigen::Vector3d(v[3 * i], v[3 * i + 1], v[3 * i + 2]));
  }
  return s * params_[b].density;
}

double Simulation::kinetic_energy(int b) const {
  const double* v = velocity(b);
  double e = 0;
  for (int i = 0; i < grid_.node_count; ++i)
    for (int k = 0; k < 3; ++k) e += grid_.node_volume[i] * v[3 * i + k] * v[3 * i + k];
  return 0.5 * params_[b].density * e;
}

std::vector<double> Simulation::cell_youngs(int b) const {
  const PhysicalParameters& p = params_[b];
  const ops::PartContext<double> cx{grid_.h, grid_.cell_count, grid_.node_count, 0, 0, 0};
  const double gradient[3] = {p.stiffness_gradient[0], p.stiffness_gradient[1], p.stiffness_gradient[2]};
  std::vector<double> E(grid_.cell_count);
  for (int c = 0; c < grid_.cell_count; ++c)
    ops::stiffness_field_cell(c, cx, &p.youngs_modulus, graph_.region_youngs >= 0 ? p.region_youngs.data() : nullptr,
                              graph_.stiffness_gradient >= 0 ? gradient : nullptr, grid_.cell_region_share.data(),
                              grid_.region_count.data(), grid_.cell_offset.data(), E.data());
  return E;
}

Simulation::CellScan Simulation::scan_cells(int b) const {
  const double* u = displacement(b);
  const std::vector<double> E = cell_youngs(b);
  double e = 0;
  int inverted = 0;
#pragma omp parallel for schedule(static) reduction(+ : e, inverted) if (grid_.cell_count >= kCellParallelThreshold)
  for (int c = 0; c < grid_.cell_count; ++c) {
    Vec3<double> uc[8];
    ops::load_cell_corners(u, grid_.cell_nodes.data(), c, uc);
    const Mat3<double> F = ops::cell_deformation_gradient(uc, grid_.h);
    inverted += ssc::det(F) <= 0;
    double lambda, mu;
    ops::lame_from_young(E[c], params_[b].poisson_ratio, lambda, mu);
    if (graph_.neo_hookean) {
      e += ops::neo_hookean_energy(grid_.cell_volume_weights.data() + 8 * c, lambda, mu, grid_.h, uc);
      continue;
    }
    Mat3<double> R;
    ops::polar_rotation(F, R);
    e += ops::corotated_energy(R, grid_.cell_volume_weights.data() + 8 * c, lambda, mu, grid_.h, uc);
  }
  return {e, inverted};
}

double Simulation::elastic_energy(int b) const { return scan_cells(b).elastic; }

int Simulation::inverted_cell_count(int b) const { return scan_cells(b).inverted; }

double Simulation::gravitational_energy(int b) const {
  const double* u = displacement(b);
  const Eigen::Vector3d& g = params_[b].gravity;
  double e = 0;
  for (int i = 0; i < grid_.node_count; ++i)
    for (int k = 0; k < 3; ++k) e -= grid_.node_volume[i] * g[k] * (grid_.node_rest[3 * i + k] + u[3 * i + k]);
  return e * params_[b].density;
}

double Simulation::contact_energy(int b) const {
  const double* u = displacement(b);
  double e = 0;
  for (const PlaneSpec& plane : params_[b].planes) {
    const Eigen::Vector3d n = plane.normal.normalized();
    for (const ContactPoint& c : grid_.contact_points) {
      double d = -plane.height;
      for (int a = 0; a < 3; ++a) d += n[a] * c.at(grid_.node_rest, a, u);
      e += plane.stiffness * c.area * softmin_potential(d, plane.softmin_alpha);
    }
  }
  return e;
}

Eigen::Vector3d Simulation::probe(int b, const Eigen::Vector3d& start_point) const {
  Eigen::Vector3d local;
  const Eigen::Vector3d rest_point = grid_.pose.rest(start_point);
  const int cell = find_cell(grid_, rest_point, &local);
  if (cell < 0)
    throw InputError(fmt::format("probe ({}, {}, {}) is not inside a cell of the body; give a point on or in the object "
                                 "where it starts",
                                 start_point.x(), start_point.y(), start_point.z()));
  const double* u = displacement(b);
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  for (int c = 0; c < 8; ++c) {
    double w = 1;
    for (int a = 0; a < 3; ++a) w *= ((c >> a) & 1) ? local[a] : 1 - local[a];
    const int n = grid_.cell_nodes[8 * cell + c];
    d += w * Eigen::Vector3d(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
  }
  return rest_point + d - start_point;
}

}  // namespace ssc
