// The GPU forward timestep (see cuda_runtime.h).
#include "runtime/cuda_runtime.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <functional>

#include "codegen/cuda_source.h"
#include "codegen/kernel_plan.h"
#include "models/io/errors.h"
#include "runtime/cuda_driver.h"

namespace ssc {

std::string gpu_unavailable_reason() {
  std::string why;
  if (!cu::driver(&why)) return "no usable GPU: " + why;
  if (!nvrtc_available()) return "no usable GPU: ssc was built without NVRTC";
  return "";
}

std::string gpu_description() {
  std::string why;
  const cu::Driver* d = cu::driver(&why);
  if (!d) return "no usable GPU: " + why;
  cu::Device dev;
  char name[256] = {};
  int major = 0, minor = 0;
  if (d->DeviceGet(&dev, 0) != 0) return "no usable GPU: cuDeviceGet failed";
  d->DeviceGetName(name, sizeof name, dev);
  d->DeviceGetAttribute(&major, cu::kAttrComputeCapabilityMajor, dev);
  d->DeviceGetAttribute(&minor, cu::kAttrComputeCapabilityMinor, dev);
  return fmt::format("{} (sm_{}{})", name, major, minor);
}

namespace {

constexpr int kBlock = 128;

struct Buffer {
  cu::DevicePtr ptr = 0;
  size_t bytes = 0;
};

// Per-launch bindings of solver vectors and values.
struct Call {
  std::map<std::string, cu::DevicePtr> vectors;
  std::map<std::string, double> values;
  long len = 0;
};

}  // namespace

struct GpuTimestep::Impl {
  const Graph& graph;
  const SimGrid& grid;
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
  std::map<std::string, Buffer> grid_buffers, scratch;
  std::vector<int> cg_iterations;
  std::map<std::string, GpuKernelTiming> timing;
  double compile_s = 0;

  Impl(const Graph& g, const SimGrid& gr, int b, const SolverOptions& s, const GpuOptions& o)
      : graph(g), grid(gr), batch(b), solver(s), options(o) {}

  ~Impl() {
    if (!d) return;
    d->CtxSetCurrent(ctx);
    for (Buffer& x : tensors) d->MemFree(x.ptr);
    for (auto& [n, x] : grid_buffers) d->MemFree(x.ptr);
    for (auto& [n, x] : scratch) d->MemFree(x.ptr);
    for (auto& [n, m] : modules) d->ModuleUnload(m);
    d->DevicePrimaryCtxRelease(device);
  }

  Buffer alloc(size_t bytes) {
    Buffer b;
    b.bytes = std::max<size_t>(bytes, 16);
    cu::check(d->MemAlloc(&b.ptr, b.bytes), "cuMemAlloc");
    cu::check(d->MemsetD8(b.ptr, 0, b.bytes), "cuMemsetD8");
    return b;
  }

  // Host doubles -> device Real.
  std::vector<char> to_real(const double* v, size_t n) const {
    std::vector<char> out(n * real_size);
    for (size_t i = 0; i < n; ++i) {
      if (real_size == 8)
        std::memcpy(out.data() + 8 * i, &v[i], 8);
      else {
        const float f = float(v[i]);
        std::memcpy(out.data() + 4 * i, &f, 4);
      }
    }
    return out;
  }
  void upload_real(const std::string& name, const std::vector<double>& v) {
    const std::vector<char> bytes = to_real(v.data(), v.size());
    Buffer b = alloc(bytes.size());
    if (!bytes.empty()) cu::check(d->MemcpyHtoD(b.ptr, bytes.data(), bytes.size()), "upload grid");
    grid_buffers["g_" + name] = b;
  }
  void upload_int(const std::string& name, const std::vector<int>& v) {
    Buffer b = alloc(v.size() * sizeof(int));
    if (!v.empty()) cu::check(d->MemcpyHtoD(b.ptr, v.data(), v.size() * sizeof(int)), "upload grid");
    grid_buffers["g_" + name] = b;
  }

  void upload_grid() {
    const SimGrid& g = grid;
    upload_int("cell_nodes", g.cell_nodes);
    upload_real("cell_weights", g.cell_volume_weights);
    upload_real("node_volume", g.node_volume);
    upload_real("node_rest", g.node_rest);
    upload_int("node_cell_offset", g.node_cell_offset);
    upload_int("node_cell_entry", g.node_cell_entry);
    std::vector<int> pn;
    std::vector<double> pt, pa;
    for (const CollisionPoint& p : g.collision_points) {
      pn.push_back(p.node_a);
      pn.push_back(p.node_b);
      pt.push_back(p.t);
      pa.push_back(p.area);
    }
    upload_int("point_nodes", pn);
    upload_real("point_t", pt);
    upload_real("point_area", pa);
    upload_int("node_point_offset", g.node_point_offset);
    upload_int("node_point_entry", g.node_point_entry);
    upload_int("band_neighbors", g.band_neighbors);
    upload_int("band_degree", g.band_degree);
    // node <- band incidence in (band, direction) order: the adjoint extension gathers it.
    std::vector<std::vector<int>> nb(g.node_count);
    for (int i = 0; i < g.band_count; ++i)
      for (int k = 0; k < 6; ++k)
        if (g.band_neighbors[6 * i + k] <= -2) nb[-g.band_neighbors[6 * i + k] - 2].push_back(i);
    std::vector<int> off{0}, ent;
    for (const auto& l : nb) {
      ent.insert(ent.end(), l.begin(), l.end());
      off.push_back(int(ent.size()));
    }
    upload_int("node_band_offset", off);
    upload_int("node_band_entry", ent);
  }

  size_t count(Domain dm) const { return size_t(sizes.count(dm)); }

  void setup() {
    std::string why;
    d = cu::driver(&why);
    if (!d) throw GpuUnavailable("no usable GPU: " + why);
    if (!nvrtc_available()) throw GpuUnavailable("no usable GPU: ssc was built without NVRTC");
    cu::check(d->DeviceGet(&device, 0), "cuDeviceGet");
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
    for (const TensorInfo& t : graph.tensors())
      if (t.name == "ground_planes") plane_count = t.components / 6;

    plan = plan_kernels(graph);
    std::vector<KernelSource> sources;
    for (const PlannedKernel& k : plan.forward)
      if (!k.duplicate) sources.push_back({k.name, kernel_source(k, {options.real, kBlock})});
    NvrtcOptions no;
    no.arch = options.arch;
    no.fmad = options.fmad;
    const auto start = std::chrono::steady_clock::now();
    const std::vector<CompiledKernel> compiled = compile_kernels(sources, no);
    compile_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
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

    for (const TensorInfo& t : graph.tensors())
      tensors.push_back(alloc(size_t(batch) * count(t.domain) * t.components * real_size));
    upload_grid();
    // Scratch: the largest request per name; solver vectors for the longer of node/band.
    std::map<std::string, size_t> need;
    for (const PlannedKernel& k : plan.forward)
      for (const KernelParam& p : k.params)
        if (p.kind == KernelParam::Kind::Scratch) {
          const size_t elem = p.type == "double" ? 8 : p.type == "int" ? 4 : real_size;
          need[p.name] = std::max(need[p.name], size_t(batch) * count(p.domain) * p.components * elem);
        }
    const size_t len_max = 3 * size_t(std::max(sizes.node, sizes.band));
    need["s_partial"] = size_t(batch) * 4 * ((len_max + kDotChunk - 1) / kDotChunk + 1) * 8;
    for (const char* v : {"v_r", "v_z", "v_p", "v_q", "v_b", "v_inv_diag"}) need[v] = size_t(batch) * len_max * real_size;
    for (auto& [n, bytes] : need) scratch[n] = alloc(bytes);
    cg_iterations.assign(batch, 0);
  }

  size_t extent_count(Extent e, long len) const {
    switch (e) {
      case Extent::One: return 1;
      case Extent::Cell: return sizes.cell;
      case Extent::Node: return sizes.node;
      case Extent::Point: return sizes.point;
      case Extent::Band: return sizes.band;
      case Extent::Len: return size_t(len);
      case Extent::LenChunks: return size_t((len + kDotChunk - 1) / kDotChunk);
    }
    return 0;
  }

  void launch(const PlannedKernel& k, const Call& call = {}) {
    const size_t n = extent_count(k.extent, call.len);
    if (n == 0 || batch == 0) return;
    std::vector<unsigned long long> slots;
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
        case KernelParam::Kind::Adjoint:
          slots.push_back(tensors.at(p.tensor).ptr);
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
    std::vector<void*> args;
    for (unsigned long long& s : slots) args.push_back(&s);
    const unsigned blocks = unsigned((n + kBlock - 1) / kBlock);
    const auto start = std::chrono::steady_clock::now();
    cu::check(d->LaunchKernel(functions.at(k.name), blocks, unsigned(batch), 1, kBlock, 1, 1, 0, nullptr, args.data(),
                              nullptr),
              ("cuLaunchKernel " + k.name).c_str());
    if (options.profile) {
      cu::check(d->CtxSynchronize(), ("kernel " + k.name).c_str());
      GpuKernelTiming& t = timing[k.name];
      t.name = k.name;
      t.launches++;
      t.ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      t.registers = registers[k.name];
    }
  }

  const PlannedKernel& kernel(const std::string& label) const {
    const PlannedKernel* k = plan.find(false, label);
    if (!k) throw std::logic_error("gpu: the plan has no kernel " + label);
    return *k;
  }

  std::vector<double> solver_state() const {
    std::vector<double> s(size_t(batch) * 16);
    cu::check(d->MemcpyDtoH(s.data(), scratch.at("s_cg").ptr, s.size() * 8), "download solver state");
    return s;
  }

  // Jacobi-PCG on x (length len per batch item) with b and inv_diag already in v_b,
  // v_inv_diag; apply(p, q) launches q = A p. Returns the iterations per batch item.
  std::vector<int> pcg(cu::DevicePtr x, long len, double tol, int max_it, const std::function<void(cu::DevicePtr, cu::DevicePtr)>& apply,
                       const char* what) {
    Call c;
    c.len = len;
    c.values = {{"tol", tol}, {"max_it", double(max_it)}};
    const cu::DevicePtr r = scratch.at("v_r").ptr, z = scratch.at("v_z").ptr, p = scratch.at("v_p").ptr,
                        q = scratch.at("v_q").ptr, b = scratch.at("v_b").ptr, inv = scratch.at("v_inv_diag").ptr;
    c.vectors = {{"v_x", x}, {"v_b", b}, {"v_r", r}, {"v_z", z}, {"v_p", p}, {"v_q", q}, {"v_inv_diag", inv}};
    auto dot = [&](cu::DevicePtr u, cu::DevicePtr w, int slot) {
      Call dc = c;
      dc.vectors["v_x"] = u;
      dc.vectors["v_y"] = w;
      dc.values["slot"] = slot;
      launch(kernel("pcg_dot"), dc);
    };
    dot(b, b, 0);
    launch(kernel("pcg_norm_b"), c);
    apply(x, q);
    launch(kernel("pcg_start"), c);
    dot(r, z, 0);
    dot(r, r, 1);
    launch(kernel("pcg_scalars_start"), c);
    const int check_every = std::max(1, options.check_every);
    for (int it = 0;; ++it) {
      if (it % check_every == 0) {
        const std::vector<double> s = solver_state();
        bool any = false;
        for (int k = 0; k < batch; ++k) any |= s[16 * k + 6] != 0.0;
        if (!any || it > max_it + check_every) break;
      }
      apply(p, q);
      dot(p, q, 0);
      launch(kernel("pcg_scalars_step"), c);
      launch(kernel("pcg_update"), c);
      dot(r, z, 0);
      dot(r, r, 1);
      launch(kernel("pcg_scalars_end"), c);
      launch(kernel("pcg_direction"), c);
    }
    const std::vector<double> s = solver_state();
    std::vector<int> iterations(batch);
    for (int k = 0; k < batch; ++k) {
      iterations[k] = int(s[16 * k + 7]);
      if (s[16 * k + 9] == 0.0)
        throw SimulationError(fmt::format("the {} did not converge on the GPU (batch item {}): relative residual "
                                          "{:.3g} after {} CG iterations (tolerance {:.3g})",
                                          what, k, s[16 * k + 8], iterations[k], tol));
    }
    return iterations;
  }

  int tensor_id(const OpNode& op, const char* slot, bool output) const {
    return output ? op.output(slot) : op.input(slot);
  }

  void newmark(int o) {
    const OpNode& op = graph.ops()[o];
    const cu::DevicePtr u = tensors.at(op.output("u")).ptr, rhs = tensors.at(op.input("rhs")).ptr;
    launch(kernel("newmark_init"));
    launch(kernel("newmark_diag"));
    Call setup;
    setup.vectors = {{"v_rhs", rhs}, {"v_x", u}, {"v_b", scratch.at("v_b").ptr}, {"v_inv_diag", scratch.at("v_inv_diag").ptr}};
    setup.values = {{"zero_x", 0}};
    launch(kernel("newmark_setup"), setup);
    auto apply = [&](cu::DevicePtr p, cu::DevicePtr q) {
      Call a;
      a.vectors = {{"v_p", p}, {"v_q", q}};
      launch(kernel("newmark_apply_cell"), a);
      launch(kernel("newmark_apply_node"), a);
    };
    cg_iterations = pcg(u, 3L * sizes.node, solver.cg_tolerance, solver.cg_max_iterations, apply, "time-step solve");
    // cg_iterations output (one Real per batch item)
    std::vector<double> its(cg_iterations.begin(), cg_iterations.end());
    const std::vector<char> bytes = to_real(its.data(), its.size());
    cu::check(d->MemcpyHtoD(tensors.at(op.output("cg_iterations")).ptr, bytes.data(), bytes.size()), "upload iterations");
  }

  void extension(int o) {
    const OpNode& op = graph.ops()[o];
    const cu::DevicePtr x = tensors.at(op.output("band_u")).ptr;
    Call setup;
    setup.vectors = {{"v_b", scratch.at("v_b").ptr}, {"v_inv_diag", scratch.at("v_inv_diag").ptr}};
    launch(kernel("extension_setup"), setup);
    auto apply = [&](cu::DevicePtr p, cu::DevicePtr q) {
      Call a;
      a.vectors = {{"v_p", p}, {"v_q", q}};
      launch(kernel("extension_apply"), a);
    };
    pcg(x, 3L * sizes.band, solver.extension_tolerance, solver.extension_max_iterations, apply, "displacement extension");
  }

  void run() {
    cu::check(d->CtxSetCurrent(ctx), "cuCtxSetCurrent");
    int solved = -1;
    for (const PlannedKernel& k : plan.forward) {
      if (k.stage.empty()) {
        launch(k);
        continue;
      }
      const int o = k.parts.front().op;
      if (o == solved) continue;
      solved = o;
      if (graph.ops()[o].kind == OpKind::NewmarkSolve)
        newmark(o);
      else
        extension(o);
    }
    cu::check(d->CtxSynchronize(), "forward step");
  }
};

GpuTimestep::GpuTimestep(const Graph& graph, const SimGrid& grid, int batch, const SolverOptions& solver,
                         const GpuOptions& options)
    : impl_(std::make_unique<Impl>(graph, grid, batch, solver, options)) {
  impl_->setup();
}

GpuTimestep::~GpuTimestep() = default;

void GpuTimestep::upload(const TensorStore<double>& store) {
  Impl& m = *impl_;
  cu::check(m.d->CtxSetCurrent(m.ctx), "cuCtxSetCurrent");
  for (size_t t = 0; t < m.graph.tensors().size(); ++t) {
    if (m.graph.tensor(int(t)).role == TensorInfo::Role::Intermediate) continue;
    const std::vector<double>& v = store.all(int(t));
    const std::vector<char> bytes = m.to_real(v.data(), v.size());
    if (!bytes.empty()) cu::check(m.d->MemcpyHtoD(m.tensors[t].ptr, bytes.data(), bytes.size()), "upload tensor");
  }
}

void GpuTimestep::run() { impl_->run(); }

void GpuTimestep::download(TensorStore<double>& store) const {
  const Impl& m = *impl_;
  for (size_t t = 0; t < m.graph.tensors().size(); ++t) {
    std::vector<double>& v = store.all(int(t));
    std::vector<char> bytes(v.size() * m.real_size);
    if (bytes.empty()) continue;
    cu::check(m.d->MemcpyDtoH(bytes.data(), m.tensors[t].ptr, bytes.size()), "download tensor");
    for (size_t i = 0; i < v.size(); ++i) {
      if (m.real_size == 8)
        std::memcpy(&v[i], bytes.data() + 8 * i, 8);
      else {
        float f;
        std::memcpy(&f, bytes.data() + 4 * i, 4);
        v[i] = f;
      }
    }
  }
}

const std::vector<int>& GpuTimestep::cg_iterations() const { return impl_->cg_iterations; }
double GpuTimestep::compile_seconds() const { return impl_->compile_s; }
int GpuTimestep::kernel_count() const { return int(impl_->functions.size()); }
std::vector<GpuKernelTiming> GpuTimestep::timings() const {
  std::vector<GpuKernelTiming> out;
  for (const auto& [n, t] : impl_->timing) out.push_back(t);
  return out;
}

}  // namespace ssc
