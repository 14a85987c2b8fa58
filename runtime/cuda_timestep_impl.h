// The state of a GpuTimestep (cuda_runtime.h), shared by the launch machinery
// (cuda_runtime.cpp: modules, buffers, argument packing, graph segments, the PCG loop)
// and the step drivers (cuda_step_drivers.cpp: which kernels a forward and an adjoint
// step launch, in which order). Internal to runtime/.
#pragma once
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "codegen/kernel_plan.h"
#include "ops/newmark.h"
#include "runtime/band_operator.h"
#include "runtime/cuda_driver.h"
#include "runtime/cuda_runtime.h"

namespace ssc {
namespace gpu_detail {

constexpr int kBlock = 128;

// A kernel launch with its argument slots (each argument in 8 bytes).
struct Pending {
  const PlannedKernel* kernel = nullptr;
  cu::Function function = nullptr;
  unsigned grid_x = 1, grid_y = 1, block = kBlock;
  bool cooperative = false;  // Extent::Grid: all blocks resident (cuLaunchCooperativeKernel)
  std::vector<unsigned long long> slots;
};

struct Buffer {
  cu::DevicePtr ptr = 0;
  size_t bytes = 0;
};

// Per-launch bindings of solver vectors and values.
struct Call {
  std::map<std::string, cu::DevicePtr> vectors;
  std::map<std::string, double> values;
  long len = 0;
  unsigned blocks = 0;  // Extent::Grid: blocks per batch item
};

// A grid solve launched in this step whose outcome (s_cg_log slot) the host reads after
// the step: iterations and convergence per batch item.
struct SolveCheck {
  int slot = 0;
  std::string what;
  double tolerance = 0;
  std::vector<int>* iterations = nullptr;  // filled per batch item
  bool add = false;                        // added to *iterations instead
};

}  // namespace gpu_detail

struct GpuTimestep::Impl {
  using Buffer = gpu_detail::Buffer;
  using Call = gpu_detail::Call;
  using Pending = gpu_detail::Pending;
  using SolveCheck = gpu_detail::SolveCheck;
  using Apply = std::function<void(cu::DevicePtr, cu::DevicePtr, int)>;

  const Graph& graph;
  const StaticArrays& grid;
  int batch;
  SolverOptions solver;
  GpuOptions options;
  const cu::Driver* d = nullptr;
  cu::Device device = 0;
  cu::Context ctx = nullptr;
  size_t real_size = 8;
  DomainSizes sizes;
  int plane_count = 0;
  KernelPlan plan;
  std::map<std::string, cu::Module> modules;
  std::map<std::string, cu::Function> functions;
  std::map<std::string, int> registers;
  std::vector<Buffer> tensors;
  // Cotangents, allocated with the adjoint kernels: one arena, the inputs' first (so each
  // clear is one memset), a view per tensor; the copy kept by save_adjoints.
  Buffer tensor_arena, adjoint_arena, saved_adjoints, chain_staging;
  size_t adjoint_input_bytes = 0;
  // State snapshots by key, and released buffers kept for reuse (cuMemFree synchronises).
  std::map<int, Buffer> snapshots;
  std::vector<Buffer> spare_snapshots;
  std::vector<Buffer> adjoints;
  std::map<std::string, Buffer> grid_buffers, scratch;
  std::vector<int> cg_iterations, adjoint_cg_iterations;
  bool adjoint_ready = false;
  // The adjoint extension solve starts from the previous (later) step's solution, except
  // on the first step of a backward pass (as the interpreter does).
  bool fresh_backward = true;
  bool adjoint_reference_set = false;  // an adjoint time-step solve of this step has run
  bool warm_adjoint_solves = false;    // in run_adjoint (not in run_kernels, as run_op_adjoint)
  std::map<std::string, GpuKernelTiming> timing;
  double compile_s = 0;
  // Launch segments between host checks of the solver state. With graphs, each segment
  // is captured once (stream capture) under its tag and replayed afterwards: the launch
  // sequence of a tag never depends on device data, only on the plan and the bindings
  // (kernel arguments included), which are fixed per tag.
  bool use_graphs = false;
  cu::Stream capture_stream = nullptr;
  std::map<std::string, cu::GraphExec> graph_execs;
  std::vector<cu::Graph> graph_list;
  std::string segment_tag;
  bool replaying = false;  // the open segment has a graph: launches are not recorded
  std::vector<Pending> pending;
  int segment_count = 0;
  std::map<std::string, int> last_iterations;  // per solve tag: the most iterations of an item, last time
  std::string segment_prefix = "segment";
  // Persistent grid solves (one cooperative kernel per solve, no host checks inside a
  // step): on when the driver and device support cooperative launches and every batch
  // item gets at least one block of each grid kernel (SSC_GPU_GRID_SOLVES=0: off).
  bool grid_solves = false;
  int multiprocessors = 0;
  int grid_min_blocks = 1;  // the grid kernels' second __launch_bounds__ argument
  std::map<std::string, int> grid_capacity;  // per grid kernel: resident blocks on the device
  std::string extension_grid;                 // the extension's grid kernel (GpuOptions::extension_phases)
  std::string newmark_grid = "newmark_pcg_grid";  // the time-step system's grid kernel (GpuOptions::newmark_phases)
  // The extension as one product (GpuOptions::dense_extension), uploaded as g_band_operator
  // and g_band_sources; nullptr: the PCG.
  std::shared_ptr<const BandExtensionOperator> dense_extension;
  std::vector<SolveCheck> solve_checks;       // this step's grid solves, read after it

  Impl(const Graph& g, const StaticArrays& gr, int b, const SolverOptions& s, const GpuOptions& o)
      : graph(g), grid(gr), batch(b), solver(s), options(o) {}
  ~Impl();

  // cuda_runtime.cpp: machinery
  void setup();
  void ensure_adjoint();  // compiles the adjoint kernels and allocates cotangents, once
  void compile_and_load(const std::vector<const PlannedKernel*>& kernels);
  void allocate_scratch(const std::vector<PlannedKernel>& kernels);
  Buffer alloc(size_t bytes);
  std::vector<char> to_real(const double* v, size_t n) const;
  void from_real(const std::vector<char>& bytes, double* v, size_t n) const;
  void put(cu::DevicePtr dst, const double* v, size_t n, const char* what);
  void get(double* v, cu::DevicePtr src, size_t n, const char* what) const;
  void upload_real(const std::string& name, const std::vector<double>& v);
  void upload_int(const std::string& name, const std::vector<int>& v);
  void upload_grid();
  size_t count(Domain dm) const { return size_t(sizes.count(dm)); }
  size_t extent_count(Extent e, long len) const;
  void launch(const PlannedKernel& k, const Call& call = {});
  void submit(Pending& pl, cu::Stream stream);
  void open_segment(const std::string& tag);
  bool recording() const { return !replaying; }
  void close_segment();
  // The kernel with this label (of op `op` where op >= 0: each solve binds its own tensors).
  const PlannedKernel& kernel(const std::string& label, bool adjoint = false, int op = -1) const;
  std::vector<double> solver_state() const;
  // reference_mode: the residual's reference (gen::residual_scale), 0 for a relative one.
  std::vector<int> pcg(cu::DevicePtr x, long len, double tol, int max_it, const Apply& apply, const char* what,
                       const std::string& tag, int reference_mode);
  void decide_grid_solves();
  void decide_newmark_grid();  // in decide_grid_solves, once the capacities are known
  unsigned grid_blocks(const PlannedKernel& k, long work) const;
  // cuCtxSynchronize, which must not meet another thread's stream capture on this GPU: the
  // simulations of one process share each GPU's context (diagnose's fits side by side), and a
  // context-wide wait fails the capture under way (CUDA error 900). Captures hold this GPU's
  // lock alone (capture_lock), waits share it, and so do frees and module loads and unloads,
  // which may wait for the device too.
  void synchronize(const char* what);
  // Blocks per item a grid kernel over `work` nodes would take with the device to itself.
  long wanted_blocks(long work) const;
  void decide_grid_min_blocks();
  // iterations_out: assigned the solve's iterations per item, or added to with reference_mode != 0
  // (the step's adjoint time-step solves, summed). rhs, x_start and x_before: a Newmark grid
  // solve's setup (its right-hand side; how x starts, ops::NewmarkXStart; the warm chain's
  // earlier solution); galerkin_start: a forward time-step solve's start (ops/galerkin_start.h).
  void grid_pcg(const PlannedKernel& k, cu::DevicePtr x, long work, double tol, int max_it, cu::DevicePtr iterations,
                const char* what, std::vector<int>* iterations_out, int reference_mode, cu::DevicePtr rhs = 0,
                int x_start = ops::kKeepX, cu::DevicePtr x_before = 0, bool galerkin_start = false);
  void read_solve_checks();
  void write_iterations(int tensor, const std::vector<int>& iterations);

  // cuda_step_drivers.cpp: what a step launches
  Apply newmark_apply(int op);
  Apply extension_apply();
  void launch_plan(const PlannedKernel* begin, const PlannedKernel* end, const std::string& first_segment,
                   const std::function<void(int)>& solve, const char* what);
  void solve_forward(int op);
  void solve_adjoint(int op);
  void newmark_setup(int op, cu::DevicePtr rhs, cu::DevicePtr x, int x_start);
  void newmark(int op);
  void clear_warm_starts();
  std::vector<Buffer> runs(const std::vector<int>& tensors) const;  // of adjacent tensor buffers  // the adjoint time-step solves' warm starts, for a new backward pass
  void extension(int op);
  // The step's first op_count ops (every op: the graph's op count).
  void run(int op_count);
  void adjoint_newmark(int op);
  void adjoint_extension(int op);
  void run_adjoint(int op_count);
};

}  // namespace ssc
