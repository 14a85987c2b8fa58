// Several cells per element apply (see element_packs.h).
#include "runtime/element_packs.h"

#include <stdexcept>
#include <string>

#include "ops/corotation.h"
#include "ops/elasticity.h"
#include "runtime/pcg.h"

namespace ssc {
namespace {

// N lanes of T in one SIMD register (GCC vector extensions): four doubles or eight floats.
template <class T, int N>
struct Pack {
  typedef T Lanes __attribute__((vector_size(N * sizeof(T))));
  Lanes v;
  Pack() = default;
  Pack(double x) {  // NOLINT: Real(0), Real(1) in the ops
    for (int l = 0; l < N; ++l) v[l] = T(x);
  }
  explicit Pack(Lanes l) : v(l) {}
  // A branch of the ops on a value: taken when every lane takes it.
  bool operator==(Pack o) const {
    for (int l = 0; l < N; ++l)
      if (v[l] != o.v[l]) return false;
    return true;
  }
};
template <class T, int N> inline Pack<T, N> operator+(Pack<T, N> a, Pack<T, N> b) { return Pack<T, N>(a.v + b.v); }
template <class T, int N> inline Pack<T, N> operator-(Pack<T, N> a, Pack<T, N> b) { return Pack<T, N>(a.v - b.v); }
template <class T, int N> inline Pack<T, N> operator*(Pack<T, N> a, Pack<T, N> b) { return Pack<T, N>(a.v * b.v); }
template <class T, int N> inline Pack<T, N> operator/(Pack<T, N> a, Pack<T, N> b) { return Pack<T, N>(a.v / b.v); }
template <class T, int N> inline Pack<T, N> operator-(Pack<T, N> a) { return Pack<T, N>(-a.v); }
template <class T, int N> inline Pack<T, N>& operator+=(Pack<T, N>& a, Pack<T, N> b) { a.v += b.v; return a; }
template <class T, int N> inline Pack<T, N>& operator-=(Pack<T, N>& a, Pack<T, N> b) { a.v -= b.v; return a; }
template <class T, int N> inline Pack<T, N>& operator*=(Pack<T, N>& a, Pack<T, N> b) { a.v *= b.v; return a; }

// Cells first .. first + N - 1.
template <class T, int N>
inline void apply_pack(int first, T h, const T* rotation, const T* weights, const T* lambda, const T* mu, const T* p,
                       const int* cell_nodes, T* corner) {
  using P = Pack<T, N>;
  Mat3<P> R;
  P w[8], la, m;
  Vec3<P> pc[8], y[8];
  for (int l = 0; l < N; ++l) {
    const int e = first + l;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) R.m[i][j].v[l] = rotation[9 * e + 3 * i + j];
    for (int c = 0; c < 8; ++c) {
      w[c].v[l] = weights[8 * e + c];
      const int n = cell_nodes[8 * e + c];
      for (int k = 0; k < 3; ++k) pc[c][k].v[l] = p[3 * n + k];
    }
    la.v[l] = lambda[e];
    m.v[l] = mu[e];
  }
  ops::corotated_apply(R, w, la, m, P(h), pc, y);
  for (int l = 0; l < N; ++l)
    for (int c = 0; c < 8; ++c)
      for (int k = 0; k < 3; ++k) corner[24 * (first + l) + 3 * c + k] = y[c][k].v[l];
}

// flatten: the ops are inlined into each clone, so no call passes a pack between code built
// for different targets (a call left out of line read garbage: NaN in the first solve).
__attribute__((target_clones("avx2", "default"), flatten)) void apply_four(int first, double h, const double* rotation,
                                                                   const double* weights, const double* lambda,
                                                                   const double* mu, const double* p,
                                                                   const int* cell_nodes, double* corner) {
  apply_pack<double, 4>(first, h, rotation, weights, lambda, mu, p, cell_nodes, corner);
}

// Eight doubles in one AVX-512 register (the dragon's CPU step against four: docs/benchmarks.md,
// session 36).
__attribute__((target("avx512f"), flatten)) void apply_eight_wide(int first, double h, const double* rotation,
                                                                 const double* weights, const double* lambda,
                                                                 const double* mu, const double* p,
                                                                 const int* cell_nodes, double* corner) {
  apply_pack<double, 8>(first, h, rotation, weights, lambda, mu, p, cell_nodes, corner);
}

__attribute__((target_clones("avx2", "default"), flatten)) void apply_eight(int first, float h, const float* rotation,
                                                                    const float* weights, const float* lambda,
                                                                    const float* mu, const float* p,
                                                                    const int* cell_nodes, float* corner) {
  apply_pack<float, 8>(first, h, rotation, weights, lambda, mu, p, cell_nodes, corner);
}

}  // namespace

namespace {

// The packs of N cells, then the tail one cell at a time.
template <int N, class T, class Pack>
void apply_cells(Pack&& apply_pack_at, int cell_count, T h, const T* rotation, const T* weights, const T* lambda,
                 const T* mu, const T* p, const int* cell_nodes, T* corner) {
  const int groups = cell_count / N;
#pragma omp parallel for schedule(static) if (cell_count >= kCellParallelThreshold)
  for (int q = 0; q < groups; ++q) apply_pack_at(N * q, h, rotation, weights, lambda, mu, p, cell_nodes, corner);
  const ops::PartContext<T> cx{h, cell_count, 0, 0, 0, 0};
  for (int e = N * groups; e < cell_count; ++e)
    ops::stiffness_apply_cell(e, cx, rotation, weights, lambda, mu, p, cell_nodes, corner);
}

}  // namespace

int cell_pack_width() {
  static const int width = __builtin_cpu_supports("avx512f") ? 8 : 4;
  return width;
}

void stiffness_apply_cells(int cell_count, double h, const double* rotation, const double* weights,
                           const double* lambda, const double* mu, const double* p, const int* cell_nodes,
                           double* corner, int pack) {
  if (pack == 0) pack = cell_pack_width();
  if (pack != 4 && !(pack == 8 && cell_pack_width() == 8))
    throw std::logic_error("stiffness_apply_cells: no pack of " + std::to_string(pack) + " cells on this CPU");
  if (pack == 8)
    apply_cells<8>(apply_eight_wide, cell_count, h, rotation, weights, lambda, mu, p, cell_nodes, corner);
  else
    apply_cells<4>(apply_four, cell_count, h, rotation, weights, lambda, mu, p, cell_nodes, corner);
}

void stiffness_apply_cells(int cell_count, float h, const float* rotation, const float* weights, const float* lambda,
                           const float* mu, const float* p, const int* cell_nodes, float* corner) {
  apply_cells<8>(apply_eight, cell_count, h, rotation, weights, lambda, mu, p, cell_nodes, corner);
}

}  // namespace ssc
