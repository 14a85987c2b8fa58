// Four cells per element apply (see element_packs.h).
#include "runtime/element_packs.h"

#include "ops/corotation.h"
#include "ops/elasticity.h"
#include "runtime/pcg.h"

namespace ssc {
namespace {

struct Pack4 {
  typedef double Lanes __attribute__((vector_size(32)));
  Lanes v;
  Pack4() = default;
  Pack4(double x) : v{x, x, x, x} {}  // NOLINT: Real(0), Real(1) in the ops
  explicit Pack4(Lanes l) : v(l) {}
  // A branch of the ops on a value: taken when every lane takes it.
  bool operator==(Pack4 o) const {
    for (int l = 0; l < 4; ++l)
      if (v[l] != o.v[l]) return false;
    return true;
  }
};
inline Pack4 operator+(Pack4 a, Pack4 b) { return Pack4(a.v + b.v); }
inline Pack4 operator-(Pack4 a, Pack4 b) { return Pack4(a.v - b.v); }
inline Pack4 operator*(Pack4 a, Pack4 b) { return Pack4(a.v * b.v); }
inline Pack4 operator/(Pack4 a, Pack4 b) { return Pack4(a.v / b.v); }
inline Pack4 operator-(Pack4 a) { return Pack4(-a.v); }
inline Pack4& operator+=(Pack4& a, Pack4 b) { a.v += b.v; return a; }
inline Pack4& operator-=(Pack4& a, Pack4 b) { a.v -= b.v; return a; }
inline Pack4& operator*=(Pack4& a, Pack4 b) { a.v *= b.v; return a; }

// Cells first .. first + 3.
__attribute__((target_clones("avx2", "default"))) void apply_four(int first, double h, const double* rotation,
                                                                   const double* weights, const double* lambda,
                                                                   const double* mu, const double* p,
                                                                   const int* cell_nodes, double* corner) {
  Mat3<Pack4> R;
  Pack4 w[8], la, m;
  Vec3<Pack4> pc[8], y[8];
  for (int l = 0; l < 4; ++l) {
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
  ops::corotated_apply(R, w, la, m, Pack4(h), pc, y);
  for (int l = 0; l < 4; ++l)
    for (int c = 0; c < 8; ++c)
      for (int k = 0; k < 3; ++k) corner[24 * (first + l) + 3 * c + k] = y[c][k].v[l];
}

}  // namespace

void stiffness_apply_cells(int cell_count, double h, const double* rotation, const double* weights,
                           const double* lambda, const double* mu, const double* p, const int* cell_nodes,
                           double* corner) {
  const int groups = cell_count / 4;
#pragma omp parallel for schedule(static) if (cell_count >= kCellParallelThreshold)
  for (int q = 0; q < groups; ++q) apply_four(4 * q, h, rotation, weights, lambda, mu, p, cell_nodes, corner);
  const ops::PartContext<double> cx{h, cell_count, 0, 0, 0, 0};
  for (int e = 4 * groups; e < cell_count; ++e)
    ops::stiffness_apply_cell(e, cx, rotation, weights, lambda, mu, p, cell_nodes, corner);
}

}  // namespace ssc
