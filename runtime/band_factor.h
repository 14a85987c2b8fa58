// The band Laplacian of the displacement extension (the "band_laplacian" schedule,
// runtime/solvers.cpp) factored once per grid for the CPU interpreter: the matrix depends on the
// grid alone, the same for every step, batch item, parameter value and component, so a sparse
// Cholesky factorisation (LDL^T, fill-reducing ordering) replaces a Jacobi-PCG solve per step
// by two triangular solves. The GPU multiplies by the dense block of the inverse that the
// extension needs, formed from this factor (runtime/band_operator.h), or runs its PCG. Grids
// with more band nodes than kDirectBandNodes keep the PCG on the CPU too (the factor's fill
// grows faster than the band).
#pragma once
#include <memory>
#include <mutex>

#include "runtime/static_arrays.h"

namespace ssc {

constexpr int kDirectBandNodes = 60000;

class BandLaplacianFactor {
 public:
  explicit BandLaplacianFactor(const StaticArrays& g);
  ~BandLaplacianFactor();
  bool ok() const;  // factorised (the matrix is SPD: every band node touches the body through the band)
  // x = L^-1 rhs for the three interleaved components (3 * band_count values each).
  void solve(const double* rhs, double* x) const;
  void solve(const float* rhs, float* x) const;
  // x = L^-1 rhs for `count` scalar right-hand sides (band_count values each, one after another).
  void solve_columns(int count, const double* rhs, double* x) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Built on first use, once, whichever batch item's thread asks first.
class BandFactorCache {
 public:
  // nullptr where the grid has no band or more than kDirectBandNodes band nodes, or the
  // factorisation failed: the caller solves iteratively.
  const BandLaplacianFactor* get(const StaticArrays& g);

 private:
  std::once_flag once_;
  std::unique_ptr<BandLaplacianFactor> factor_;
};

}  // namespace ssc
