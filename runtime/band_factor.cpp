// The band Laplacian's sparse Cholesky factor (see band_factor.h).
#include "runtime/band_factor.h"

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <vector>

namespace ssc {

struct BandLaplacianFactor::Impl {
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  bool ok = false;
  int n = 0;
};

BandLaplacianFactor::BandLaplacianFactor(const StaticArrays& g) : impl_(std::make_unique<Impl>()) {
  const int n = g.band_count;
  impl_->n = n;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(7 * size_t(n));
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, double(g.band_degree[size_t(i)]));
    for (int d = 0; d < 6; ++d)
      if (const int nb = g.band_neighbors[6 * size_t(i) + size_t(d)]; nb >= 0) t.emplace_back(i, nb, -1.0);
  }
  Eigen::SparseMatrix<double> L(n, n);
  L.setFromTriplets(t.begin(), t.end());
  impl_->ldlt.compute(L);
  impl_->ok = impl_->ldlt.info() == Eigen::Success;
}

BandLaplacianFactor::~BandLaplacianFactor() = default;

bool BandLaplacianFactor::ok() const { return impl_->ok; }

void BandLaplacianFactor::solve(const double* rhs, double* x) const {
  const int n = impl_->n;
  Eigen::MatrixXd b(n, 3);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) b(i, k) = rhs[3 * size_t(i) + size_t(k)];
  const Eigen::MatrixXd y = impl_->ldlt.solve(b);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) x[3 * size_t(i) + size_t(k)] = y(i, k);
}

void BandLaplacianFactor::solve(const float* rhs, float* x) const {
  std::vector<double> r(3 * size_t(impl_->n)), y(r.size());
  for (size_t i = 0; i < r.size(); ++i) r[i] = double(rhs[i]);
  solve(r.data(), y.data());
  for (size_t i = 0; i < r.size(); ++i) x[i] = float(y[i]);
}

void BandLaplacianFactor::solve_columns(int count, const double* rhs, double* x) const {
  const int n = impl_->n;
  const Eigen::Map<const Eigen::MatrixXd> b(rhs, n, count);
  Eigen::Map<Eigen::MatrixXd>(x, n, count) = impl_->ldlt.solve(b);
}

const BandLaplacianFactor* BandFactorCache::get(const StaticArrays& g) {
  std::call_once(once_, [&] {
    if (g.band_count <= 0 || g.band_count > kDirectBandNodes) return;
    auto f = std::make_unique<BandLaplacianFactor>(g);
    if (f->ok()) factor_ = std::move(f);
  });
  return factor_.get();
}

}  // namespace ssc
