// The GPU timestep's machinery (see cuda_runtime.h): compiling and loading the planned
// kernels, device buffers, argument packing, launch segments captured as CUDA graphs,
// and the Jacobi-PCG loop with host checks. What a step launches is in
// cuda_step_drivers.cpp.
#include "runtime/cuda_runtime.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <shared_mutex>

#include "codegen/cuda_source.h"
#include "runtime/errors.h"
#include "runtime/cuda_timestep_impl.h"

namespace ssc {

std::string gpu_unavailable_reason() {
  std::string why;
  if (!cu::driver(&why)) return "no usable GPU: " + why;
  if (!nvrtc_available()) return "no usable GPU: ssc was built without NVRTC";
  return "";
}

std::string gpu_description(int ordinal) {
  std::string why;
  const cu::Driver* d = cu::driver(&why);
  if (!d) return "no usable GPU: " + why;
  cu::Device dev;
  char name[256] = {};
  int major = 0, minor = 0;
  if (d->DeviceGet(&dev, ordinal) != 0) return fmt::format("no usable GPU: cuDeviceGet({}) failed", ordinal);
  d->DeviceGetName(name, sizeof name, dev);
  d->DeviceGetAttribute(&major, cu::kAttrComputeCapabilityMajor, dev);
  d->DeviceGetAttribute(&minor, cu::kAttrComputeCapabilityMinor, dev);
  return fmt::format("{} (sm_{}{})", name, major, minor);
}

int gpu_count() {
  std::string why;
  const cu::Driver* d = cu::driver(&why);
  int n = 0;
  if (!d || d->DeviceGetCount(&n) != 0) return 0;
  return n;
}

namespace {

using gpu_detail::kBlock;

// Per GPU ordinal: stream captures take it alone, context-wide waits share it (Impl::synchronize).
std::shared_mutex& capture_lock(int ordinal) {
  static std::mutex guard;
  static std::map<int, std::unique_ptr<std::shared_mutex>> locks;
  std::lock_guard<std::mutex> lock(guard);
  std::unique_ptr<std::shared_mutex>& m = locks[ordinal];
  if (!m) m = std::make_unique<std::shared_mutex>();
  return *m;
}

bool disabled_by_env(const char* name) {
  const char* e = std::getenv(name);
  return e && std::string(e) == "0";
}

// The message of a solve that did not converge for batch item `item`, from its solver
// state (16 doubles: 7 iterations, 8 relative residual; codegen/solver_kernels.cuh).
std::string solve_failure(const std::string& what, int item, const double* state, double tolerance) {
  return fmt::format("the {} did not converge on the GPU (batch item {}): relative residual {:.3g} after {} CG "
                     "iterations (tolerance {:.3g})",
                     what, item, state[8], int(state[7]), tolerance);
}

}  // namespace

GpuTimestep::Impl::~Impl() {
  if (!d) return;
  std::shared_lock<std::shared_mutex> no_capture(capture_lock(options.ordinal));  // frees may wait for the device
  d->CtxSetCurrent(ctx);
  for (Buffer* x : {&tensor_arena, &adjoint_arena, &saved_adjoints, &chain_staging})
    if (x->ptr) d->MemFree(x->ptr);
  for (auto& [n, x] : grid_buffers) d->MemFree(x.ptr);
  for (auto& [k, x] : snapshots) d->MemFree(x.ptr);
  for (Buffer& x : spare_snapshots) d->MemFree(x.ptr);
  for (auto& [n, x] : scratch) d->MemFree(x.ptr);
  for (auto& [n, e] : graph_execs) d->GraphExecDestroy(e);
  for (cu::Graph g : graph_list) d->GraphDestroy(g);
  if (capture_stream) d->StreamDestroy(capture_stream);
  for (auto& [n, m] : modules) d->ModuleUnload(m);
  d->DevicePrimaryCtxRelease(device);
}

GpuTimestep::Impl::Buffer GpuTimestep::Impl::alloc(size_t bytes) {
  Buffer b;
  b.bytes = std::max<size_t>(bytes, 16);
  std::shared_lock<std::shared_mutex> no_capture(capture_lock(options.ordinal));
  cu::check(d->MemAlloc(&b.ptr, b.bytes), "cuMemAlloc");
  cu::check(d->MemsetD8(b.ptr, 0, b.bytes), "cuMemsetD8");
  return b;
}

// Host doubles -> device Real.
std::vector<char> GpuTimestep::Impl::to_real(const double* v, size_t n) const {
  std::vector<char> out(n * real_size);
  for (size_t i = 0; i < n; ++i) {
    if (real_size == 8) {
      std::memcpy(out.data() + 8 * i, &v[i], 8);
    } else {
      const float f = float(v[i]);
      std::memcpy(out.data() + 4 * i, &f, 4);
    }
  }
  return out;
}

// Host doubles to device Real and back; doubles travel without a staging copy.
void GpuTimestep::Impl::put(cu::DevicePtr dst, const double* v, size_t n, const char* what) {
  if (n == 0) return;
  if (real_size == 8) {
    cu::check(d->MemcpyHtoD(dst, v, n * 8), what);
    return;
  }
  const std::vector<char> bytes = to_real(v, n);
  cu::check(d->MemcpyHtoD(dst, bytes.data(), bytes.size()), what);
}

void GpuTimestep::Impl::get(double* v, cu::DevicePtr src, size_t n, const char* what) const {
  if (n == 0) return;
  if (real_size == 8) {
    cu::check(d->MemcpyDtoH(v, src, n * 8), what);
    return;
  }
  std::vector<char> bytes(n * real_size);
  cu::check(d->MemcpyDtoH(bytes.data(), src, bytes.size()), what);
  from_real(bytes, v, n);
}

void GpuTimestep::Impl::from_real(const std::vector<char>& bytes, double* v, size_t n) const {
  for (size_t i = 0; i < n; ++i) {
    if (real_size == 8) {
      std::memcpy(&v[i], bytes.data() + 8 * i, 8);
    } else {
      float f;
      std::memcpy(&f, bytes.data() + 4 * i, 4);
      v[i] = f;
    }
  }
}

void GpuTimestep::Impl::upload_real(const std::string& name, const std::vector<double>& v) {
  const std::vector<char> bytes = to_real(v.data(), v.size());
  Buffer b = alloc(bytes.size());
  if (!bytes.empty()) cu::check(d->MemcpyHtoD(b.ptr, bytes.data(), bytes.size()), "upload grid");
  grid_buffers["g_" + name] = b;
}

void GpuTimestep::Impl::upload_int(const std::string& name, const std::vector<int>& v) {
  Buffer b = alloc(v.size() * sizeof(int));
  if (!v.empty()) cu::check(d->MemcpyHtoD(b.ptr, v.data(), v.size() * sizeof(int)), "upload grid");
  grid_buffers["g_" + name] = b;
}

void GpuTimestep::Impl::upload_grid() {
  for (const NamedStaticArray& a : named_static_arrays(grid)) {
    if (a.is_int)
      upload_int(a.name, a.ints);
    else
      upload_real(a.name, a.reals);
  }
}

void GpuTimestep::Impl::compile_and_load(const std::vector<const PlannedKernel*>& kernels) {
  std::vector<KernelSource> sources;
  for (const PlannedKernel* k : kernels)
    if (!k->duplicate && !functions.count(k->name)) {
      CodegenOptions co{options.real, kBlock};
      co.grid_min_blocks = grid_min_blocks;
      sources.push_back({k->name, kernel_source(*k, co)});
    }
  NvrtcOptions no;
  no.arch = options.arch;
  no.fmad = options.fmad;
  const auto start = std::chrono::steady_clock::now();
  const std::vector<CompiledKernel> compiled = compile_kernels(sources, no);
  compile_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::shared_lock<std::shared_mutex> no_capture(capture_lock(options.ordinal));
  for (const CompiledKernel& c : compiled) {
    cu::Module m;
    cu::check(d->ModuleLoadData(&m, c.image.data()), ("cuModuleLoadData " + c.name).c_str());
    modules[c.name] = m;
    cu::Function f;
    cu::check(d->ModuleGetFunction(&f, m, c.name.c_str()), ("cuModuleGetFunction " + c.name).c_str());
    functions[c.name] = f;
    int regs = 0;
    d->FuncGetAttribute(&regs, cu::kFuncAttrNumRegs, f);
    registers[c.name] = regs;
  }
}

// Scratch: the largest request per name over the kernels (and over earlier calls).
void GpuTimestep::Impl::allocate_scratch(const std::vector<PlannedKernel>& kernels) {
  std::map<std::string, size_t> need;
  for (const PlannedKernel& k : kernels)
    for (const KernelParam& p : k.params)
      if (p.kind == KernelParam::Kind::Scratch) {
        const size_t elem = p.type == "double" ? 8 : p.type == "int" ? 4 : real_size;
        need[p.name] = std::max(need[p.name], size_t(batch) * count(p.domain) * p.components * elem);
      }
  // Solver vectors, for the longer of node and band vectors.
  const size_t len_max = 3 * size_t(std::max(sizes.node, sizes.band));
  for (const char* v : {"v_r", "v_z", "v_p", "v_q", "v_b", "v_inv_diag", "v_w", "v_s", "v_r2", "v_w2", "v_s2"})
    need[v] = size_t(batch) * len_max * real_size;
  need["v_iterations_sink"] = size_t(batch) * real_size;  // iteration counts nobody reads on the device
  for (size_t o = 0; o < graph.ops().size(); ++o)  // the adjoint solves' warm chain (clear_warm_starts)
    if (graph.ops()[o].spec->solver == "newmark_pcg")
      need[fmt::format("s_w_before_op{}", o)] = size_t(batch) * 3 * size_t(sizes.node) * real_size;
  for (auto& [n, bytes] : need) {
    auto it = scratch.find(n);
    if (it != scratch.end() && it->second.bytes >= bytes) continue;
    if (it != scratch.end()) {  // captured graphs hold the old pointer: capture anew
      std::shared_lock<std::shared_mutex> no_capture(capture_lock(options.ordinal));
      d->MemFree(it->second.ptr);
      for (auto& [tag, e] : graph_execs) d->GraphExecDestroy(e);
      graph_execs.clear();
    }
    scratch[n] = alloc(bytes);
  }
}

void GpuTimestep::Impl::setup() {
  std::string why;
  d = cu::driver(&why);
  if (!d) throw GpuUnavailable("no usable GPU: " + why);
  if (!nvrtc_available()) throw GpuUnavailable("no usable GPU: ssc was built without NVRTC");
  if (options.ordinal < 0 || options.ordinal >= gpu_count())
    throw GpuUnavailable(fmt::format("no usable GPU: there is no GPU {} (the driver lists {})", options.ordinal,
                                     gpu_count()));
  cu::check(d->DeviceGet(&device, options.ordinal), "cuDeviceGet");
  cu::check(d->DevicePrimaryCtxRetain(&ctx, device), "cuDevicePrimaryCtxRetain");
  cu::check(d->CtxSetCurrent(ctx), "cuCtxSetCurrent");
  if (options.arch.empty()) {
    int major = 0, minor = 0;
    d->DeviceGetAttribute(&major, cu::kAttrComputeCapabilityMajor, device);
    d->DeviceGetAttribute(&minor, cu::kAttrComputeCapabilityMinor, device);
    options.arch = fmt::format("sm_{}{}", major, minor);
  }
  real_size = options.real == "float" ? 4 : 8;
  sizes = domain_sizes(grid);
  plane_count = graph.plane_count();

  plan = plan_kernels(graph);
  decide_grid_min_blocks();
  std::vector<const PlannedKernel*> forward;
  for (const PlannedKernel& k : plan.forward) forward.push_back(&k);
  compile_and_load(forward);
  // One arena, the inputs first, then the states and intermediates in tensor order, each
  // 256-byte aligned: a stored step (all but the inputs) is one copy.
  std::vector<size_t> offset(graph.tensors().size()), bytes(graph.tensors().size());
  size_t end = 0;
  for (bool inputs : {true, false})
    for (size_t t = 0; t < graph.tensors().size(); ++t) {
      const TensorInfo& info = graph.tensor(int(t));
      if ((info.role == TensorInfo::Role::Input) != inputs) continue;
      bytes[t] = std::max<size_t>(size_t(batch) * count(info.domain) * info.components * real_size, 16);
      offset[t] = end;
      end += (bytes[t] + 255) / 256 * 256;
    }
  tensor_arena = alloc(end);
  for (size_t t = 0; t < graph.tensors().size(); ++t) tensors.push_back({tensor_arena.ptr + offset[t], bytes[t]});
  upload_grid();
  if (options.dense_extension && !disabled_by_env("SSC_GPU_DENSE_EXTENSION") && plan.find(false, "extension_dense"))
    dense_extension = band_extension_operator(grid);
  if (dense_extension) {
    upload_real("band_operator", dense_extension->columns);
    upload_int("band_sources", dense_extension->sources);
  }
  allocate_scratch(plan.forward);
  cg_iterations.assign(batch, 0);
  use_graphs = options.graphs && !options.profile && !disabled_by_env("SSC_GPU_GRAPHS") && d->has_graphs() &&
               d->StreamCreate(&capture_stream, cu::kStreamNonBlocking) == 0;
  if (!use_graphs) capture_stream = nullptr;
  decide_grid_solves();
}

void GpuTimestep::Impl::decide_grid_solves() {
  grid_solves = false;
  int cooperative = 0;
  d->DeviceGetAttribute(&cooperative, cu::kAttrCooperativeLaunch, device);
  d->DeviceGetAttribute(&multiprocessors, cu::kAttrMultiprocessorCount, device);
  if (!options.grid_solves || disabled_by_env("SSC_GPU_GRID_SOLVES") || !d->has_cooperative() || !cooperative)
    return;
  bool fits = true;
  for (const PlannedKernel& k : plan.forward) {
    if (k.extent != Extent::Grid || grid_capacity.count(k.name)) continue;
    int per_sm = 0;
    cu::check(d->OccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, functions.at(k.name), kGridBlock, 0),
              ("cuOccupancyMaxActiveBlocksPerMultiprocessor " + k.name).c_str());
    grid_capacity[k.name] = per_sm * multiprocessors;
    fits &= per_sm * multiprocessors >= batch;
  }
  grid_solves = fits && !grid_capacity.empty();
  decide_newmark_grid();
  const PlannedKernel* one_phase = plan.find(false, "extension_pcg_grid");
  if (!grid_solves || !one_phase) return;  // a graph without the extension has no choice to make
  int phases = options.extension_phases;
  if (const char* e = std::getenv("SSC_GPU_EXTENSION_PHASES")) phases = std::atoi(e);
  // Measured on an H200 (whole steps): two phases pay from about two band nodes per thread
  // (batch 32: 10-27% faster), one phase up to about one (batch 1: 13-29%; batch 8: 0-10%).
  if (phases != 1 && phases != 2)
    phases = 2L * grid_blocks(*one_phase, sizes.band) * kGridBlock <= sizes.band ? 2 : 1;
  extension_grid = phases == 2 ? "extension_pcg_grid_two_phase" : "extension_pcg_grid";
}

// The time-step system's grid kernel: one phase per iteration where every cell corner of an
// item has a thread, else two. Measured on an H200 (docs/benchmarks.md, session 31; ms a
// step): the peer's dragon at batch 1 0.58 against 0.78-0.86 (one phase without the registers
// of CornerLane: 0.65); the torus 0.18 against 0.20; the CalculiX cube at batch 16 0.595
// against 0.556; where threads loop over corners (the cube at batch 64 1.44 against 1.10, the
// dragon at batch 32 4.0 against 2.0) two phases. The choice must not depend on the batch
// beyond the blocks an item gets: the two forms sum in different orders, and an item's bits
// must not change with what runs beside it (docs/cli.md; BatchEvaluation.APointsValuesDoNotDependOnTheBatchBesideIt
// failed on an H100 when batch 1 alone took one phase). One phase needs every node in some
// cell (its owner is a corner).
void GpuTimestep::Impl::decide_newmark_grid() {
  newmark_grid = "newmark_pcg_grid";
  const PlannedKernel* one_phase = plan.find(false, "newmark_pcg_grid_one_phase");
  if (!grid_solves || !one_phase) return;
  int phases = options.newmark_phases;
  if (const char* e = std::getenv("SSC_GPU_NEWMARK_PHASES")) phases = std::atoi(e);
  const long corners = 8L * sizes.cell;
  if (phases != 1 && phases != 2)
    phases = long(grid_blocks(*one_phase, corners)) * kGridBlock >= corners ? 1 : 2;
  for (size_t n = 0; phases == 1 && n + 1 < grid.node_cell_offset.size(); ++n)
    if (grid.node_cell_offset[n + 1] == grid.node_cell_offset[n]) phases = 2;
  if (phases == 1) newmark_grid = "newmark_pcg_grid_one_phase";
}

// The persistent solves' register cap. Uncapped (the one-phase solve takes 255 registers),
// they hold two blocks of 128 threads per multiprocessor; where the batch wants several times
// more blocks (one thread per cell corner), each block loops over several corners and the
// solve is throughput-bound, and three blocks per multiprocessor (at most 170 registers) hide
// more latency. Measured with blocks of 256 threads (three of them: at most 85 registers) on
// an H100 (docs/benchmarks.md): the dragon at batch 32 (12x the multiprocessors) 1.30x faster
// forward, 1.35x adjoint; at batch 1 the cap costs 11 %; the CalculiX cube at batch 16 (2.7x)
// gained nothing, at batch 64 (11x) 6 %. With 128-thread blocks and this cap, batch 32 ran as
// fast as before or faster (docs/benchmarks.md, session 33). In float, six blocks (at most 85
// registers): the dragon at batch 32 1.66 ms a step against 1.93 with three; in double six
// took 2.39 against 2.00 (one H200, docs/benchmarks.md, session 35).
void GpuTimestep::Impl::decide_grid_min_blocks() {
  d->DeviceGetAttribute(&multiprocessors, cu::kAttrMultiprocessorCount, device);
  const long wanted = wanted_blocks(std::max({8L * sizes.cell, long(sizes.node), long(sizes.band)})) * batch;
  const int throughput_blocks = real_size == 4 ? 6 : 3;
  grid_min_blocks =
      options.grid_min_blocks > 0 ? options.grid_min_blocks : wanted > 4L * multiprocessors ? throughput_blocks : 1;
  if (const char* e = std::getenv("SSC_GPU_GRID_MIN_BLOCKS")) grid_min_blocks = std::max(1, std::atoi(e));
}

// One node per thread (SSC_GPU_GRID_SPREAD=s: s per thread).
long GpuTimestep::Impl::wanted_blocks(long work) const {
  double spread = 1;
  if (const char* e = std::getenv("SSC_GPU_GRID_SPREAD")) spread = std::max(0.01, std::atof(e));
  return std::clamp<long>(long(std::ceil(double(work) / (kGridBlock * spread))), 1, kMaxGridBlocks);
}

void GpuTimestep::Impl::synchronize(const char* what) {
  std::shared_lock<std::shared_mutex> shared(capture_lock(options.ordinal));
  cu::check(d->CtxSynchronize(), what);
}

// Blocks per batch item for a grid kernel over `work` threads' worth of nodes or cells: those
// wanted, at most what keeps every block of the batch resident.
unsigned GpuTimestep::Impl::grid_blocks(const PlannedKernel& k, long work) const {
  const long fit = std::min<long>(kMaxGridBlocks, grid_capacity.at(k.name) / batch);
  return unsigned(std::clamp<long>(wanted_blocks(work), 1, std::max<long>(1, fit)));
}

void GpuTimestep::Impl::ensure_adjoint() {
  if (adjoint_ready) return;
  std::vector<const PlannedKernel*> adjoint;
  for (const PlannedKernel& k : plan.adjoint) adjoint.push_back(&k);
  compile_and_load(adjoint);
  allocate_scratch(plan.adjoint);
  clear_warm_starts();  // zero-filled by alloc, which would read as solutions
  // Inputs first, each view 256-byte aligned.
  const size_t n = graph.tensors().size();
  std::vector<size_t> offset(n);
  size_t end = 0;
  for (bool inputs : {true, false}) {
    for (size_t t = 0; t < n; ++t) {
      const TensorInfo& info = graph.tensor(int(t));
      if ((info.role == TensorInfo::Role::Input) != inputs) continue;
      offset[t] = end;
      end += (size_t(batch) * count(info.domain) * info.components * real_size + 255) / 256 * 256;
    }
    if (inputs) adjoint_input_bytes = end;
  }
  adjoint_arena = alloc(end);
  for (size_t t = 0; t < n; ++t) {
    const TensorInfo& info = graph.tensor(int(t));
    adjoints.push_back({adjoint_arena.ptr + offset[t], size_t(batch) * count(info.domain) * info.components * real_size});
  }
  adjoint_cg_iterations.assign(batch, 0);
  adjoint_ready = true;
}

size_t GpuTimestep::Impl::extent_count(Extent e, long len) const {
  switch (e) {
    case Extent::One: return 1;
    case Extent::Cell: return sizes.cell;
    case Extent::Node: return sizes.node;
    case Extent::Point: return sizes.point;
    case Extent::Band: return sizes.band;
    case Extent::Len: return size_t(len);
    case Extent::Item: return 1;
    case Extent::Grid: return 1;
  }
  return 0;
}

void GpuTimestep::Impl::launch(const PlannedKernel& k, const Call& call) {
  if (replaying) return;  // the open segment is replayed from its graph
  const size_t n = extent_count(k.extent, call.len);
  if (n == 0 || batch == 0) return;
  Pending pl;
  pl.kernel = &k;
  pl.function = functions.at(k.name);
  std::vector<unsigned long long>& slots = pl.slots;
  slots.reserve(8 + k.params.size());
  auto put_int = [&](long v) {
    unsigned long long s = 0;
    const int i = int(v);
    std::memcpy(&s, &i, 4);
    slots.push_back(s);
  };
  auto put_double = [&](double v) {
    unsigned long long s = 0;
    std::memcpy(&s, &v, 8);
    slots.push_back(s);
  };
  auto put_real = [&](double v) {
    if (real_size == 8) return put_double(v);
    unsigned long long s = 0;
    const float f = float(v);
    std::memcpy(&s, &f, 4);
    slots.push_back(s);
  };
  put_int(sizes.cell);
  put_int(sizes.node);
  put_int(sizes.point);
  put_int(sizes.band);
  put_int(plane_count);
  put_int(batch);
  put_real(grid.h);
  for (const KernelParam& p : k.params) {
    switch (p.kind) {
      case KernelParam::Kind::Tensor:
        slots.push_back(tensors.at(p.tensor).ptr);
        break;
      case KernelParam::Kind::Adjoint:
        if (!adjoint_ready) throw std::logic_error("gpu: cotangent of " + k.name + " before ensure_adjoint()");
        slots.push_back(adjoints.at(p.tensor).ptr);
        break;
      case KernelParam::Kind::Grid:
        slots.push_back(grid_buffers.at(p.name).ptr);
        break;
      case KernelParam::Kind::Scratch:
        slots.push_back(scratch.at(p.name).ptr);
        break;
      case KernelParam::Kind::Vector: {
        auto it = call.vectors.find(p.name);
        if (it == call.vectors.end()) throw std::logic_error("gpu: unbound vector " + p.name + " of " + k.name);
        slots.push_back(it->second);
        break;
      }
      case KernelParam::Kind::Value: {
        if (p.name == "len") {
          put_int(call.len);
          break;
        }
        auto it = call.values.find(p.name);
        if (it == call.values.end()) throw std::logic_error("gpu: unbound value " + p.name + " of " + k.name);
        if (p.type == "double")
          put_double(it->second);
        else
          put_int(long(it->second));
        break;
      }
    }
  }
  if (k.extent == Extent::Item) {
    pl.grid_x = 1;
    pl.block = kItemBlock;
  } else if (k.extent == Extent::Grid) {
    if (call.blocks == 0) throw std::logic_error("gpu: grid kernel " + k.name + " launched without a block count");
    pl.grid_x = call.blocks;
    pl.block = kGridBlock;
    pl.cooperative = true;
  } else {
    pl.grid_x = unsigned((n + kBlock - 1) / kBlock);
    pl.block = kBlock;
  }
  pl.grid_y = unsigned(batch);
  if (use_graphs)
    pending.push_back(std::move(pl));
  else
    submit(pl, nullptr);
}

void GpuTimestep::Impl::submit(Pending& pl, cu::Stream stream) {
  std::vector<void*> args;
  args.reserve(pl.slots.size());
  for (unsigned long long& s : pl.slots) args.push_back(&s);
  const std::string& name = pl.kernel->name;
  const auto start = std::chrono::steady_clock::now();
  if (pl.cooperative)
    cu::check(d->LaunchCooperativeKernel(pl.function, pl.grid_x, pl.grid_y, 1, pl.block, 1, 1, 0, stream, args.data()),
              ("cuLaunchCooperativeKernel " + name).c_str());
  else
    cu::check(d->LaunchKernel(pl.function, pl.grid_x, pl.grid_y, 1, pl.block, 1, 1, 0, stream, args.data(), nullptr),
              ("cuLaunchKernel " + name).c_str());
  if (options.profile) {
    synchronize(("kernel " + name).c_str());
    GpuKernelTiming& t = timing[name];
    t.name = name;
    t.launches++;
    t.ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    t.registers = registers[name];
  }
}

// Opens a launch segment named `tag` (graphs only): if it was captured before, the
// launches until close_segment() are skipped and the graph is replayed instead.
void GpuTimestep::Impl::open_segment(const std::string& tag) {
  if (!use_graphs) return;
  segment_tag = tag;
  replaying = graph_execs.count(tag) != 0;
  pending.clear();
}

// Submits the open segment (on the legacy stream, ordered with the copies).
void GpuTimestep::Impl::close_segment() {
  if (!use_graphs) return;
  if (!replaying && !pending.empty()) {
    cu::Graph captured = nullptr;
    std::unique_lock<std::shared_mutex> alone(capture_lock(options.ordinal));
    cu::check(d->StreamBeginCapture(capture_stream, cu::kCaptureModeThreadLocal), "cuStreamBeginCapture");
    try {
      for (Pending& pl : pending) submit(pl, capture_stream);
      cu::check(d->StreamEndCapture(capture_stream, &captured), "cuStreamEndCapture");
    } catch (const std::exception& e) {
      if (!captured) d->StreamEndCapture(capture_stream, &captured);
      if (captured) d->GraphDestroy(captured);
      // A driver that cannot capture this segment (cooperative launches, say): launch
      // directly from now on.
      fmt::print(stderr, "ssc: CUDA graphs off ({}); launching kernels directly\n", e.what());
      use_graphs = false;
      for (Pending& pl : pending) submit(pl, nullptr);
      pending.clear();
      replaying = false;
      return;
    }
    graph_list.push_back(captured);
    cu::GraphExec exec = nullptr;
    cu::check(d->GraphInstantiate(&exec, captured, 0), "cuGraphInstantiate");
    graph_execs[segment_tag] = exec;
  }
  auto it = graph_execs.find(segment_tag);
  if (it != graph_execs.end()) cu::check(d->GraphLaunch(it->second, nullptr), "cuGraphLaunch");
  pending.clear();
  replaying = false;
}

const PlannedKernel& GpuTimestep::Impl::kernel(const std::string& label, bool adjoint, int op) const {
  const PlannedKernel* k = plan.find(adjoint, label, op);
  if (!k) throw std::logic_error("gpu: the plan has no kernel " + label);
  return *k;
}

std::vector<double> GpuTimestep::Impl::solver_state() const {
  std::vector<double> s(size_t(batch) * 16);
  cu::check(d->MemcpyDtoH(s.data(), scratch.at("s_cg").ptr, s.size() * 8), "download solver state");
  return s;
}

// Jacobi-PCG on x (length len per batch item) with b and inv_diag already in v_b,
// v_inv_diag; apply(p, q, gate) launches q = A p (gate != 0: skipped for items whose
// solve has stopped). Per iteration: the apply kernels and one block-per-item
// pcg_iterate. The host reads the solver state every check_every iterations; the
// iterations in between form one graph segment (`tag`). Returns the iterations per item.
std::vector<int> GpuTimestep::Impl::pcg(cu::DevicePtr x, long len, double tol, int max_it, const Apply& apply,
                                        const char* what, const std::string& tag, int reference_mode) {
  Call c;
  c.len = len;
  c.values = {{"tol", tol}, {"max_it", double(max_it)}, {"reference_mode", double(reference_mode)}};
  const cu::DevicePtr r = scratch.at("v_r").ptr, z = scratch.at("v_z").ptr, p = scratch.at("v_p").ptr,
                      q = scratch.at("v_q").ptr, b = scratch.at("v_b").ptr, inv = scratch.at("v_inv_diag").ptr;
  c.vectors = {{"v_x", x}, {"v_b", b}, {"v_r", r}, {"v_z", z}, {"v_p", p}, {"v_q", q}, {"v_inv_diag", inv}};
  const PlannedKernel& iterate = kernel("pcg_iterate");
  if (recording()) {
    apply(x, q, 0);
    launch(kernel("pcg_start"), c);
  }
  const int check_every = std::max(1, options.check_every);
  std::vector<double> s;
  // The first host check comes after as many iterations as this solve needed last time
  // (rounded up to check_every): consecutive steps need similar counts, and an iteration
  // launched for a solve that has already stopped returns at once, far cheaper than a
  // host check. Its own graph segment per length, so the length is capped (16 lengths at
  // most per solve: a solve that needs thousands of iterations must not capture a graph of
  // thousands of launches for every count it meets).
  int first = check_every;
  if (const auto last = last_iterations.find(tag); last != last_iterations.end())
    first = std::clamp((last->second + check_every - 1) / check_every * check_every, check_every, 16 * check_every);
  close_segment();
  open_segment(fmt::format("{}/first {}", tag, first));
  for (int it = 0;;) {
    if (it > 0) open_segment(tag + "/chunk");
    const int chunk = it == 0 ? first : check_every;
    if (recording())
      for (int k = 0; k < chunk; ++k) {
        apply(p, q, 1);
        launch(iterate, c);
      }
    close_segment();
    it += chunk;
    s = solver_state();
    bool any = false;
    for (int k = 0; k < batch; ++k) any |= s[16 * k + 6] != 0.0;
    if (!any || it > max_it + check_every) break;
  }
  open_segment(fmt::format("{} {}", segment_prefix, ++segment_count));
  std::vector<int> iterations(batch);
  int most = 0;
  for (int k = 0; k < batch; ++k) most = std::max(most, int(s[16 * k + 7]));
  last_iterations[tag] = most;
  std::vector<int> failed;
  for (int k = 0; k < batch; ++k) {
    iterations[k] = int(s[16 * k + 7]);
    if (s[16 * k + 9] == 0.0) failed.push_back(k);
  }
  if (!failed.empty())
    throw SimulationError(solve_failure(what, failed[0], s.data() + 16 * failed[0], tol), failed);
  return iterations;
}

// The whole solve as one cooperative grid kernel (b and inv_diag already in v_b,
// v_inv_diag), no host check: its outcome is read after the step (read_solve_checks).
// `iterations` receives the iteration count per batch item on the device.
void GpuTimestep::Impl::grid_pcg(const PlannedKernel& k, cu::DevicePtr x, long work, double tol, int max_it,
                                 cu::DevicePtr iterations, const char* what, std::vector<int>* iterations_out,
                                 int reference_mode, cu::DevicePtr rhs, int x_start, cu::DevicePtr x_before,
                                 bool galerkin_start) {
  const int slot = int(solve_checks.size());
  if (slot >= kMaxSolveLog) throw std::logic_error("gpu: more grid solves in one step than s_cg_log holds");
  Call c;
  c.blocks = grid_blocks(k, work);
  c.values = {{"tol", tol},
              {"max_it", double(max_it)},
              {"log_slot", double(slot)},
              {"reference_mode", double(reference_mode)},
              {"x_start", double(x_start)},  // a Newmark grid solve's setup (the extension's has none)
              {"galerkin_start", galerkin_start ? 1.0 : 0.0}};  // a forward time-step solve's start
  for (const char* v : {"v_b", "v_inv_diag", "v_r", "v_w", "v_s", "v_z", "v_p", "v_r2", "v_w2", "v_s2"})
    c.vectors[v] = scratch.at(v).ptr;
  c.vectors["v_x"] = x;
  c.vectors["v_rhs"] = rhs;
  c.vectors["v_x_before"] = x_before;
  c.vectors["v_iterations"] = iterations;
  launch(k, c);
  solve_checks.push_back({slot, what, tol, iterations_out, reference_mode != 0});
}

// After a step: iterations and convergence of its grid solves, from s_cg_log.
void GpuTimestep::Impl::read_solve_checks() {
  if (solve_checks.empty()) return;
  const size_t per_item = 16 * size_t(kMaxSolveLog);
  std::vector<double> log(size_t(batch) * per_item);
  cu::check(d->MemcpyDtoH(log.data(), scratch.at("s_cg_log").ptr, log.size() * 8), "download solver states");
  const std::vector<SolveCheck> checks = std::move(solve_checks);
  solve_checks.clear();
  std::string first;
  std::vector<char> failed(batch, 0);
  for (const SolveCheck& c : checks) {
    if (c.iterations && !c.add) c.iterations->assign(batch, 0);
    for (int k = 0; k < batch; ++k) {
      const double* st = log.data() + size_t(k) * per_item + 16 * size_t(c.slot);
      if (c.iterations) (*c.iterations)[k] += int(st[7]);
      if (st[9] != 0.0) continue;
      if (first.empty())
        first = solve_failure(c.what, k, st, c.tolerance);
      failed[k] = 1;
    }
  }
  if (first.empty()) return;
  std::vector<int> items;
  for (int k = 0; k < batch; ++k)
    if (failed[k]) items.push_back(k);
  throw SimulationError(first, items);
}

// One Real per batch item.
void GpuTimestep::Impl::write_iterations(int tensor, const std::vector<int>& iterations) {
  const std::vector<double> its(iterations.begin(), iterations.end());
  const std::vector<char> bytes = to_real(its.data(), its.size());
  cu::check(d->MemcpyHtoD(tensors.at(tensor).ptr, bytes.data(), bytes.size()), "upload iterations");
}

// ---- GpuTimestep ----

GpuTimestep::GpuTimestep(const Graph& graph, const StaticArrays& grid, int batch, const SolverOptions& solver,
                         const GpuOptions& options)
    : impl_(std::make_unique<Impl>(graph, grid, batch, solver, options)) {
  impl_->setup();
}

GpuTimestep::~GpuTimestep() = default;

void GpuTimestep::upload(const TensorStore<double>& store, bool intermediates) {
  Impl& m = *impl_;
  cu::check(m.d->CtxSetCurrent(m.ctx), "cuCtxSetCurrent");
  for (size_t t = 0; t < m.graph.tensors().size(); ++t) {
    if (!intermediates && m.graph.tensor(int(t)).role == TensorInfo::Role::Intermediate) continue;
    const std::vector<double>& v = store.all(int(t));
    m.put(m.tensors[t].ptr, v.data(), v.size(), "upload tensor");
  }
}

void GpuTimestep::copy_tensors(const std::vector<std::pair<int, int>>& from_to) {
  Impl& m = *impl_;
  cu::check(m.d->CtxSetCurrent(m.ctx), "cuCtxSetCurrent");
  for (const auto& [from, to] : from_to) {
    const Impl::Buffer &a = m.tensors.at(from), &b = m.tensors.at(to);
    if (a.bytes != b.bytes) throw std::logic_error("gpu: copy_tensors between tensors of different sizes");
    cu::check(m.d->MemcpyDtoD(b.ptr, a.ptr, a.bytes), "copy tensor");
  }
}

// The tensors' memory as runs of adjacent buffers (tensor_arena): a stored step is one copy.
std::vector<GpuTimestep::Impl::Buffer> GpuTimestep::Impl::runs(const std::vector<int>& list) const {
  std::vector<Buffer> out;
  for (int t : list) {
    const Buffer& x = tensors.at(t);
    if (!out.empty() && out.back().ptr + (out.back().bytes + 255) / 256 * 256 == x.ptr)
      out.back().bytes = x.ptr + x.bytes - out.back().ptr;
    else
      out.push_back(x);
  }
  return out;
}

void GpuTimestep::save_snapshot(int key, const std::vector<int>& tensors) {
  Impl& m = *impl_;
  cu::check(m.d->CtxSetCurrent(m.ctx), "cuCtxSetCurrent");
  const std::vector<Impl::Buffer> runs = m.runs(tensors);
  size_t bytes = 0;
  for (const Impl::Buffer& r : runs) bytes += r.bytes;
  auto it = m.snapshots.find(key);
  if (it == m.snapshots.end()) {
    auto spare = std::find_if(m.spare_snapshots.begin(), m.spare_snapshots.end(),
                              [&](const Impl::Buffer& x) { return x.bytes >= bytes; });
    Impl::Buffer buffer;
    if (spare != m.spare_snapshots.end()) {
      buffer = *spare;
      m.spare_snapshots.erase(spare);
    } else {
      try {
        buffer = m.alloc(bytes);
      } catch (const std::runtime_error& e) {
        throw std::runtime_error(fmt::format("gpu: no device memory for a stored step or checkpoint of {:.1f} MB ({} "
                                             "held); lower the gradient's memory budget or the batch size ({})",
                                             bytes / 1e6, m.snapshots.size(), e.what()));
      }
    }
    it = m.snapshots.emplace(key, buffer).first;
  }
  if (it->second.bytes < bytes) throw std::logic_error("gpu: save_snapshot with more tensors than the key holds");
  size_t offset = 0;
  for (const Impl::Buffer& r : runs) {
    cu::check(m.d->MemcpyDtoD(it->second.ptr + offset, r.ptr, r.bytes), "save snapshot");
    offset += r.bytes;
  }
}

void GpuTimestep::load_snapshot(int key, const std::vector<int>& tensors) {
  Impl& m = *impl_;
  const auto it = m.snapshots.find(key);
  if (it == m.snapshots.end()) throw std::logic_error("gpu: load_snapshot of a key never saved");
  cu::check(m.d->CtxSetCurrent(m.ctx), "cuCtxSetCurrent");
  size_t offset = 0;
  for (const Impl::Buffer& r : m.runs(tensors)) {
    if (offset + r.bytes > it->second.bytes) throw std::logic_error("gpu: load_snapshot of more than was saved");
    cu::check(m.d->MemcpyDtoD(r.ptr, it->second.ptr + offset, r.bytes), "load snapshot");
    offset += r.bytes;
  }
}

void GpuTimestep::drop_snapshot(int key) {
  Impl& m = *impl_;
  const auto it = m.snapshots.find(key);
  if (it == m.snapshots.end()) return;
  m.spare_snapshots.push_back(it->second);
  m.snapshots.erase(it);
}

size_t GpuTimestep::free_device_memory() const {
  const Impl& m = *impl_;
  cu::check(m.d->CtxSetCurrent(m.ctx), "cuCtxSetCurrent");
  size_t free = 0, total = 0;
  cu::check(m.d->MemGetInfo(&free, &total), "cuMemGetInfo");
  for (const Impl::Buffer& x : m.spare_snapshots) free += x.bytes;  // kept for the next stored steps
  return free;
}

void GpuTimestep::run() { impl_->run(int(impl_->graph.ops().size())); }
void GpuTimestep::run_prefix(int op_count) { impl_->run(op_count); }

void GpuTimestep::download(TensorStore<double>& store) const {
  for (size_t t = 0; t < impl_->graph.tensors().size(); ++t) download(store, int(t));
}

void GpuTimestep::download(TensorStore<double>& store, int tensor) const {
  const Impl& m = *impl_;
  std::vector<double>& v = store.all(tensor);
  m.get(v.data(), m.tensors.at(tensor).ptr, v.size(), "download tensor");
}

void GpuTimestep::clear_adjoints(bool including_inputs) {
  Impl& m = *impl_;
  cu::check(m.d->CtxSetCurrent(m.ctx), "cuCtxSetCurrent");
  m.ensure_adjoint();
  if (including_inputs) {
    m.fresh_backward = true;
    m.clear_warm_starts();
  }
  const size_t skip = including_inputs ? 0 : m.adjoint_input_bytes;
  if (m.adjoint_arena.bytes > skip)
    cu::check(m.d->MemsetD8(m.adjoint_arena.ptr + skip, 0, m.adjoint_arena.bytes - skip), "clear cotangents");
}

void GpuTimestep::save_adjoints() {
  Impl& m = *impl_;
  cu::check(m.d->CtxSetCurrent(m.ctx), "cuCtxSetCurrent");
  m.ensure_adjoint();
  if (!m.saved_adjoints.ptr) m.saved_adjoints = m.alloc(m.adjoint_arena.bytes);
  cu::check(m.d->MemcpyDtoD(m.saved_adjoints.ptr, m.adjoint_arena.ptr, m.adjoint_arena.bytes), "save cotangents");
}

void GpuTimestep::restore_adjoints() {
  Impl& m = *impl_;
  if (!m.saved_adjoints.ptr) throw std::logic_error("gpu: restore_adjoints before save_adjoints");
  cu::check(m.d->CtxSetCurrent(m.ctx), "cuCtxSetCurrent");
  cu::check(m.d->MemcpyDtoD(m.adjoint_arena.ptr, m.saved_adjoints.ptr, m.adjoint_arena.bytes), "restore cotangents");
  m.fresh_backward = true;
  m.clear_warm_starts();
}

void GpuTimestep::set_adjoint(int tensor, const std::vector<double>& all_items) {
  Impl& m = *impl_;
  m.ensure_adjoint();
  if (all_items.size() * m.real_size > m.adjoints.at(tensor).bytes) throw std::logic_error("gpu: set_adjoint size mismatch");
  m.put(m.adjoints[tensor].ptr, all_items.data(), all_items.size(), "upload cotangent");
}

void GpuTimestep::get_adjoint(int tensor, std::vector<double>& all_items) const {
  const Impl& m = *impl_;
  if (!m.adjoint_ready) throw std::logic_error("gpu: get_adjoint before any adjoint step");
  if (all_items.size() * m.real_size > m.adjoints.at(tensor).bytes) throw std::logic_error("gpu: get_adjoint size mismatch");
  m.get(all_items.data(), m.adjoints.at(tensor).ptr, all_items.size(), "download cotangent");
}

void GpuTimestep::chain_adjoints(const std::vector<std::pair<int, int>>& from_to) {
  Impl& m = *impl_;
  cu::check(m.d->CtxSetCurrent(m.ctx), "cuCtxSetCurrent");
  m.ensure_adjoint();
  size_t bytes = 0;
  for (const auto& [from, to] : from_to) {
    if (m.adjoints.at(from).bytes != m.adjoints.at(to).bytes)
      throw std::logic_error("gpu: chain_adjoints between tensors of different sizes");
    if (m.graph.tensor(to).role == TensorInfo::Role::Input)
      throw std::logic_error("gpu: chain_adjoints into an input's cotangent");
    bytes += m.adjoints[from].bytes;
  }
  if (m.chain_staging.bytes < bytes) {
    if (m.chain_staging.ptr) {
      std::shared_lock<std::shared_mutex> no_capture(capture_lock(m.options.ordinal));
      m.d->MemFree(m.chain_staging.ptr);
    }
    m.chain_staging = m.alloc(bytes);
  }
  size_t at = 0;
  for (const auto& [from, to] : from_to) {
    cu::check(m.d->MemcpyDtoD(m.chain_staging.ptr + at, m.adjoints[from].ptr, m.adjoints[from].bytes), "chain cotangents");
    at += m.adjoints[from].bytes;
  }
  clear_adjoints(false);
  at = 0;
  for (const auto& [from, to] : from_to) {
    cu::check(m.d->MemcpyDtoD(m.adjoints[to].ptr, m.chain_staging.ptr + at, m.adjoints[to].bytes), "chain cotangents");
    at += m.adjoints[to].bytes;
  }
}

void GpuTimestep::run_adjoint() {
  impl_->ensure_adjoint();
  impl_->run_adjoint(int(impl_->graph.ops().size()));
}

void GpuTimestep::run_adjoint_prefix(int op_count) {
  impl_->ensure_adjoint();
  impl_->run_adjoint(op_count);
}

void GpuTimestep::run_kernels(bool adjoint, int first, int last) {
  Impl& m = *impl_;
  if (adjoint) m.ensure_adjoint();
  const std::vector<PlannedKernel>& plan = adjoint ? m.plan.adjoint : m.plan.forward;
  if (first < 0 || last >= int(plan.size()) || first > last) throw std::out_of_range("gpu: run_kernels range");
  const std::string tag = fmt::format("{} kernels {}-{}", adjoint ? "adjoint" : "forward", first, last);
  m.segment_prefix = tag;
  m.adjoint_reference_set = false;  // each adjoint solve to its own residual, from zero (as run_op_adjoint)
  m.warm_adjoint_solves = false;
  m.launch_plan(plan.data() + first, plan.data() + last + 1, tag + " segment 0", [&m, adjoint](int o) {
    if (adjoint)
      m.solve_adjoint(o);
    else
      m.solve_forward(o);
  }, tag.c_str());
}

const std::vector<int>& GpuTimestep::cg_iterations() const { return impl_->cg_iterations; }
const std::vector<int>& GpuTimestep::adjoint_cg_iterations() const { return impl_->adjoint_cg_iterations; }
double GpuTimestep::compile_seconds() const { return impl_->compile_s; }
int GpuTimestep::kernel_count() const { return int(impl_->functions.size()); }

int GpuTimestep::resident_items() const {
  const Impl& m = *impl_;
  if (m.grid_capacity.empty()) return std::numeric_limits<int>::max();
  const long want = m.wanted_blocks(std::max({8L * m.sizes.cell, long(m.sizes.node), long(m.sizes.band)}));
  long items = std::numeric_limits<int>::max();
  for (const auto& [name, capacity] : m.grid_capacity)
    items = std::min(items, std::max(1L, long(capacity) / std::max(1L, std::min<long>(want, capacity))));
  return int(items);
}
std::vector<GpuKernelTiming> GpuTimestep::timings() const {
  std::vector<GpuKernelTiming> out;
  for (const auto& [n, t] : impl_->timing) out.push_back(t);
  return out;
}

}  // namespace ssc
