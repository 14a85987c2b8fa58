// CUDA source generation (see cuda_source.h).
#include "codegen/cuda_source.h"

#include <fmt/format.h>

#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "codegen/embedded_ops.h"

namespace ssc {
namespace {

const char* kHelpers = R"(
namespace ssc {
namespace gen {
// Row-major 3x3 matrices stored as 9 consecutive Reals per cell (runtime/cpu_kernels.h).
template <class R>
__device__ inline Mat3<R> load_mat3(const R* r, int cell) {
  Mat3<R> m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m.m[i][j] = r[9 * cell + 3 * i + j];
  return m;
}
template <class R>
__device__ inline void store_mat3(R* r, int cell, const Mat3<R>& m) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[9 * cell + 3 * i + j] = m.m[i][j];
}
template <class R>
__device__ inline void add_mat3(R* r, int cell, const Mat3<R>& m) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[9 * cell + 3 * i + j] += m.m[i][j];
}
// Ground planes: 6 values each (normal, height, stiffness, soft-min alpha).
template <class R>
__device__ inline int load_planes(const R* q, int n, ops::GroundPlane<R>* planes) {
  if (n > ops::kMaxGroundPlanes) n = ops::kMaxGroundPlanes;
  for (int p = 0; p < n; ++p) {
    const R* x = q + 6 * p;
    planes[p].normal = make_vec3(x[0], x[1], x[2]);
    planes[p].height = x[3];
    planes[p].stiffness = x[4];
    planes[p].alpha = x[5];
  }
  return n;
}
// Sums N doubles over the Threads threads of a block in a fixed order: each warp by a
// shuffle tree, then the warp sums (in warp order) by a shuffle tree in warp 0. Every
// thread returns with the totals. All threads of the block must call it (it has barriers).
template <int N, int Threads = SSC_ITEM>
__device__ inline void block_sum(double (&v)[N]) {
  constexpr int kWarps = Threads / 32;
  __shared__ double part[N][kWarps];
  __shared__ double total[N];
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
#pragma unroll
  for (int k = 0; k < N; ++k)
    for (int o = 16; o > 0; o >>= 1) v[k] += __shfl_down_sync(0xffffffffu, v[k], o);
  if (lane == 0)
    for (int k = 0; k < N; ++k) part[k][warp] = v[k];
  __syncthreads();
  if (warp == 0) {
#pragma unroll
    for (int k = 0; k < N; ++k) {
      double s = lane < kWarps ? part[k][lane] : 0.0;
      for (int o = 16; o > 0; o >>= 1) s += __shfl_down_sync(0xffffffffu, s, o);
      if (lane == 0) total[k] = s;
    }
  }
  __syncthreads();
#pragma unroll
  for (int k = 0; k < N; ++k) v[k] = total[k];
  __syncthreads();  // part/total may be reused by the next call
}

// A vector from lane (this lane ^ mask) of the warp (all 32 lanes must take part).
template <class R>
__device__ inline Vec3<R> shfl_xor3(Vec3<R> v, int mask) {
  return make_vec3(__shfl_xor_sync(0xffffffffu, v.x, mask), __shfl_xor_sync(0xffffffffu, v.y, mask),
                   __shfl_xor_sync(0xffffffffu, v.z, mask));
}

// Extent::Grid: the threads of one batch item are gridDim.x blocks of SSC_GRID threads.
__device__ inline int grid_rank() { return blockIdx.x * SSC_GRID + threadIdx.x; }
__device__ inline int grid_threads() { return gridDim.x * SSC_GRID; }

__device__ inline unsigned long long load_acquire(const unsigned long long* p) {
  unsigned long long v;
  asm volatile("ld.acquire.gpu.global.u64 %0, [%1];" : "=l"(v) : "l"(p) : "memory");
  return v;
}
__device__ inline unsigned long long add_release(unsigned long long* p, unsigned long long v) {
  unsigned long long old;
  asm volatile("atom.release.gpu.global.add.u64 %0, [%1], %2;" : "=l"(old) : "l"(p), "l"(v) : "memory");
  return old;
}

// Barrier of the gridDim.x blocks of one batch item (all resident: cooperative launch).
// *bar counts arrivals and only grows: the barrier a block arrives at is complete when
// the count reaches the next multiple of gridDim.x (the same for every launch of one
// kernel over one problem, so the counter stays valid from launch to launch). Writes
// before the barrier (any block) are visible after it: release on arrival, acquire on
// leaving. One atomic and the polls per block.
__device__ inline void grid_sync(unsigned long long* bar) {
  __syncthreads();
  if (threadIdx.x == 0) {
    const unsigned long long blocks = gridDim.x;
    const unsigned long long target = (add_release(bar, 1ull) / blocks + 1) * blocks;
    while (load_acquire(bar) < target) {
    }
  }
  __syncthreads();
}

// Sums N doubles over all threads of one batch item in a fixed order (block trees, then
// the block totals in block order by warp 0 of every block): every thread of every block
// returns with the same bits. partial holds N * gridDim.x doubles; consecutive calls must
// use different partial buffers unless a grid_sync separates them. Includes a grid_sync.
template <int N>
__device__ inline void grid_sum(double (&v)[N], double* partial, unsigned long long* bar) {
  block_sum<N, SSC_GRID>(v);
  if (threadIdx.x == 0)
    for (int k = 0; k < N; ++k) partial[N * blockIdx.x + k] = v[k];
  grid_sync(bar);
  __shared__ double total[N];
  if (threadIdx.x < 32) {
    const int lane = threadIdx.x;
    for (int k = 0; k < N; ++k) {
      double s = 0;
      for (int j = lane; j < int(gridDim.x); j += 32) s += __ldcg(partial + N * j + k);
      for (int o = 16; o > 0; o >>= 1) s += __shfl_down_sync(0xffffffffu, s, o);
      if (lane == 0) total[k] = s;
    }
  }
  __syncthreads();
  for (int k = 0; k < N; ++k) v[k] = total[k];
  __syncthreads();
}
}  // namespace gen
}  // namespace ssc
using namespace ssc;
)";

const EmbeddedFile* find_embedded(const std::string& path) {
  for (int i = 0; i < kEmbeddedOpsCount; ++i)
    if (path == kEmbeddedOps[i].path) return &kEmbeddedOps[i];
  return nullptr;
}

// Pastes header `path` after its ops/ dependencies; include lines and #pragma once become
// comments so that line numbers stay right.
void paste(const std::string& path, std::set<std::string>& done, std::string& out) {
  if (!done.insert(path).second) return;
  const EmbeddedFile* f = find_embedded(path);
  if (!f) throw std::runtime_error("codegen: op header " + path + " is not embedded");
  std::istringstream in(f->text);
  std::string line, body;
  while (std::getline(in, line)) {
    const std::string key = "#include \"ops/";
    if (line.rfind(key, 0) == 0) {
      const std::string dep = line.substr(10, line.find('"', 10) - 10);
      paste(dep, done, out);
      body += "// " + line + " (pasted above)\n";
    } else if (line.rfind("#pragma once", 0) == 0) {
      body += "// #pragma once\n";
    } else {
      body += line + "\n";
    }
  }
  out += "#line 1 \"" + path + "\"\n" + body;
}

}  // namespace

std::string extent_count_expr(Extent e) {
  switch (e) {
    case Extent::One: return "1";
    case Extent::Cell: return "n_cell";
    case Extent::Node: return "n_node";
    case Extent::Point: return "n_point";
    case Extent::Band: return "n_band";
    case Extent::Len: return "len";
    case Extent::Item: return "1";
    case Extent::Grid: return "1";
  }
  return "1";
}

std::string kernel_prelude(const CodegenOptions& o) {
  if (o.real != "double" && o.real != "float") throw std::invalid_argument("codegen: Real must be float or double");
  std::string s = fmt::format(
      "// Generated by ssc {} (codegen/cuda_source.cpp). Real = {}, block = {}.\n"
      "#define SSC_BLOCK {}\n"
      "#define SSC_ITEM {}\n"
      "#define SSC_GRID {}\n",
      SSC_VERSION, o.real, o.block_size, o.block_size, o.item_block, kGridBlock);
  std::set<std::string> done;
  for (int i = 0; i < kEmbeddedOpsCount; ++i) paste(kEmbeddedOps[i].path, done, s);
  s += "#line 1 \"ssc_generated_prelude\"\n";
  s += fmt::format("typedef {} Real;\n", o.real);
  s += kHelpers;
  return s;
}

std::string kernel_signature_and_body(const PlannedKernel& k, const std::string& name) {
  const bool item = k.extent == Extent::Item, grid = k.extent == Extent::Grid;
  std::string sig = fmt::format(
      "extern \"C\" __global__ void __launch_bounds__({}) {}(\n"
      "    const int n_cell, const int n_node, const int n_point, const int n_band, const int n_plane,\n"
      "    const int batch, const Real h",
      item ? "SSC_ITEM" : grid ? "SSC_GRID" : "SSC_BLOCK", name);
  std::string prologue;
  for (const KernelParam& p : k.params) {
    if (p.kind == KernelParam::Kind::Value) {
      sig += fmt::format(",\n    const {} {}", p.type, p.name);
      continue;
    }
    const std::string cv = p.write ? "" : "const ";
    if (p.kind == KernelParam::Kind::Grid) {
      sig += fmt::format(",\n    const {}* __restrict__ {}", p.type, p.name);
      continue;
    }
    sig += fmt::format(",\n    {}{}* p_{}", cv, p.type, p.name);
    prologue += fmt::format("  {}{}* {} = p_{} + size_t(b) * size_t({});\n", cv, p.type, p.name, p.name, p.stride);
  }
  std::string body = sig + ") {\n";
  if (grid) {
    // The item's gridDim.x blocks all stay to the end (grid barriers).
    body += "  const int b = blockIdx.y;\n  if (b >= batch) return;\n";
  } else if (item) {
    // One block per batch item; the whole block stays (block_sum has barriers).
    body += "  const int i = threadIdx.x;\n  const int b = blockIdx.y;\n";
    body += "  if (blockIdx.x != 0 || b >= batch) return;\n";
  } else {
    body += "  const int i = blockIdx.x * blockDim.x + threadIdx.x;\n  const int b = blockIdx.y;\n";
    body += fmt::format("  if (i >= {} || b >= batch) return;\n", extent_count_expr(k.extent));
  }
  body += prologue;
  for (const Snippet& p : k.parts) {
    // Solver kernels shared by several solves must not differ by the op index.
    body += p.shared ? fmt::format("  {{  // {}\n", p.label) : fmt::format("  {{  // op {}: {}\n", p.op, p.label);
    std::istringstream in(p.code);
    std::string line;
    while (std::getline(in, line)) body += "    " + line + "\n";
    body += "  }\n";
  }
  body += "}\n";
  return body;
}

std::string kernel_function(const PlannedKernel& k) {
  return fmt::format("#line 1 \"{}.cu\"\n", k.name) + kernel_signature_and_body(k, k.name);
}

std::string kernel_source(const PlannedKernel& k, const CodegenOptions& o) {
  return kernel_prelude(o) + "\n// ---- kernel ----\n" + kernel_function(k);
}

}  // namespace ssc
