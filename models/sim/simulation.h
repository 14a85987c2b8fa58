// A batch of forward simulations of one body: the timestep graph run by the CPU
// interpreter in double, one set of physical parameters per batch item.
#pragma once
#include <Eigen/Core>
#include <map>
#include <memory>
#include <vector>

#include "models/grid/sim_grid.h"
#include "models/sim/run_audit.h"
#include "models/sim/scene.h"
#include "models/sim/timestep_graph.h"
#include "runtime/interpreter.h"

namespace ssc {

// Everything the paper optimises, per simulation.
struct PhysicalParameters {
  double youngs_modulus = 0, poisson_ratio = 0, density = 0, mass_damping = 0, stiffness_damping = 0;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
  std::vector<PlaneSpec> planes;
  std::vector<double> region_youngs;  // material.regions[k].youngs_modulus, Pa
  Eigen::Vector3d stiffness_gradient = Eigen::Vector3d::Zero();  // 1/m
  double air_drag = 0;  // kg/m^3

  static PhysicalParameters from_scene(const Scene& scene);
};

class GpuTimestep;
class StepBackend;

class Simulation {
 public:
  Simulation(const Scene& scene, const SimGrid& grid, int batch = 1, bool extension = false);
  ~Simulation();

  // Runs the steps with the generated CUDA kernels (runtime/cuda_runtime.h) instead of the
  // interpreter, forward and (models/sim/gradient.h) adjoint; throws GpuUnavailable without
  // a usable GPU. ordinal: which GPU (models/sim/compute_device.h).
  void use_gpu(const std::string& real = "double", int ordinal = 0);
  bool on_gpu() const { return gpu_ != nullptr; }
  GpuTimestep* gpu() { return gpu_; }
  // Where the steps run (runtime/step_backend.h): the interpreter or the GPU.
  StepBackend& backend() { return *backend_; }

  int batch() const { return interpreter_->batch(); }
  void set_parameters(int b, const PhysicalParameters& p);
  const PhysicalParameters& parameters(int b) const { return params_[b]; }
  // Rest state with the initial velocity; called by the constructor and set_parameters.
  void reset();
  // Advances every batch item by one step; SimulationError names the step on failure.
  // step(false) leaves the new state where the steps run (the device on the GPU):
  // sync_host() copies it back and checks it (an exploding simulation is reported there);
  // until then the state accessors below (displacement() and all built on it) throw
  // std::logic_error.
  // extend = false leaves out the band extension (a step no cost observes): the band
  // displacement then stays the last extended step's, and band_displacement() throws until
  // a step extends again.
  void step(bool to_host = true, bool extend = true);
  void sync_host();
  // step(false) that also keeps what the step read and computed (its states and
  // intermediates, all batch items) under key, where the steps run; load_step(key) puts
  // them back with the state before the step, so that the adjoint of that step can run
  // without recomputing it. step_bytes(): what one kept step holds.
  void step_and_keep(int key, bool extend = true);
  void load_step(int key);
  size_t step_bytes() const;
  int steps_taken() const { return steps_; }
  double dt() const { return dt_; }

  const double* displacement(int b) const;
  const double* velocity(int b) const;
  // nullptr without extension. With an initial pose (grid.frame "object") the engine extends the
  // displacement as ever and this adds band_pose_offset_ (simulation.cpp, pose_band_offset) into
  // a buffer of item b's, valid until the next call for b.
  const double* band_displacement(int b) const;
  const std::vector<char>& fixed_nodes() const { return fixed_; }

  Eigen::Vector3d center_of_mass(int b) const;
  Eigen::Vector3d linear_momentum(int b) const;
  Eigen::Vector3d angular_momentum(int b) const;  // about the origin
  double kinetic_energy(int b) const;
  double elastic_energy(int b) const;
  // The corotated elastic energy and the number of cells with det F <= 0 at their centre, in
  // one pass over the cells.
  struct CellScan {
    double elastic = 0;
    int inverted = 0;
  };
  CellScan scan_cells(int b) const;
  // Each cell's Young's modulus (ops/stiffness_field.h; youngs_modulus for a homogeneous body).
  std::vector<double> cell_youngs(int b) const;
  double gravitational_energy(int b) const;  // -m g . x, zero at the origin
  double contact_energy(int b) const;        // the soft-min penalty's potential (ops/contact.h)
  int inverted_cell_count(int b) const;      // cells with det F <= 0 at their centre
  // The run's sanity checks and what they saw (models/sim/run_audit.h).
  const SimulationAudit& audit(int b) const { return audits_[b]; }
  double total_mass() const;  // with batch item 0's density
  // How far a body point has moved from where it started (a world point at the start; trilinear
  // in its cell); InputError outside the body's cells.
  Eigen::Vector3d probe(int b, const Eigen::Vector3d& start_point) const;

  // The state of one batch item (what the adjoint stores per step), and its restoration.
  struct State {
    std::vector<double> u, v, band;
    std::vector<double> v_before;  // v a step earlier (the solve's start), where the graph keeps it
  };
  State state(int b) const;
  void set_state(int b, const State& s, int step);
  // Runs the step from the current state again without advancing (the adjoint's
  // recomputation of a step's intermediates), on whichever device runs the steps.
  void recompute_step(bool extend = true);
  // Whole-batch state checkpoints under a key (the adjoint's stored steps), kept where the
  // steps run (device memory on the GPU); load_checkpoint restores the state and its step.
  // drop_checkpoint releases a checkpoint or a kept step, clear_checkpoints all of them.
  void save_checkpoint(int key);
  void load_checkpoint(int key);
  void drop_checkpoint(int key);
  void clear_checkpoints();
  // The centre of mass the initial spin is taken about.
  const Eigen::Vector3d& spin_center() const { return spin_center_; }

  Interpreter<double>& interpreter() { return *interpreter_; }
  const RunReport& last_report() const { return interpreter_->report(); }
  // Cells whose rotation fell back to the identity in the last CPU step of batch item b.
  int degenerate_cells(int b) const;
  // CG iterations of the last step of batch item b, on whichever device ran it.
  int last_cg_iterations(int b) const;
  const SimGrid& grid() const { return grid_; }
  const TimestepGraph& timestep_graph() const { return graph_; }

 private:
  void write_inputs(int b);
  void check_state(int b, const char* when = "step");
  void check_states(const char* when);  // every batch item  // when: how the error names the step
  void require_host_state() const;
  void advance(bool to_host, int keep_key, bool extend);
  void run_step(bool extend);
  std::vector<int> state_tensors() const;  // u_prev, v_prev and, with the extension, band_guess; v_before
  std::vector<int> step_tensors() const;   // every state and intermediate tensor
  void keep(int key, const std::vector<int>& tensors, int step);
  void restore(int key);

  const SimGrid& grid_;
  TimestepGraph graph_;
  std::unique_ptr<Interpreter<double>> interpreter_;
  std::unique_ptr<StepBackend> backend_;  // an InterpreterBackend, or the GpuTimestep
  GpuTimestep* gpu_ = nullptr;            // backend_ when it is the GPU
  // The backend holds the host's inputs and state (set by a step, cleared by any host
  // change): a step then starts from the backend's copy, without an upload.
  bool device_current_ = false;
  // The backend holds a newer state than the host (step(false), load_checkpoint); for the
  // interpreter the two are one store, so only the checks wait for sync_host().
  bool host_stale_ = false;
  // The band displacement is the current step's (the last step extended).
  bool band_current_ = true;
  struct Kept {
    int step = 0;
    std::vector<int> tensors;
    bool band_current = true;
  };
  std::map<int, Kept> kept_;  // checkpoints and kept steps by key
  std::vector<PhysicalParameters> params_;
  std::vector<SimulationAudit> audits_;
  std::vector<char> fixed_;
  double dt_, theta_;
  int steps_ = 0;
  void pose_band_offset();
  Eigen::Vector3d spin_center_ = Eigen::Vector3d::Zero();
  std::vector<double> band_pose_offset_;                  // empty without an initial pose
  mutable std::vector<std::vector<double>> band_posed_;   // per batch item, band_displacement's
};

}  // namespace ssc
