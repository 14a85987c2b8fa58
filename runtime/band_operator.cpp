// The extension's dense operator G = L^-1 B (see band_operator.h).
#include "runtime/band_operator.h"

#include <algorithm>
#include <cstdint>
#include <map>
#include <mutex>

#include "runtime/band_factor.h"

namespace ssc {
namespace {

constexpr size_t kCachedOperators = 4;
constexpr int kColumnsPerSolve = 32;

std::uint64_t incidence_key(const StaticArrays& g) {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a
  auto mix = [&](std::uint64_t v) {
    h ^= v;
    h *= 1099511628211ull;
  };
  mix(std::uint64_t(g.band_count));
  mix(std::uint64_t(g.node_count));
  for (int v : g.band_neighbors) mix(std::uint64_t(std::uint32_t(v)));
  for (int v : g.band_degree) mix(std::uint64_t(std::uint32_t(v)));
  return h;
}

std::shared_ptr<const BandExtensionOperator> build(const StaticArrays& g) {
  const int n = g.band_count;
  std::vector<int> sources;
  for (int v : g.band_neighbors)
    if (v <= -2) sources.push_back(-v - 2);
  std::sort(sources.begin(), sources.end());
  sources.erase(std::unique(sources.begin(), sources.end()), sources.end());
  if (sources.empty() || sources.size() * size_t(n) * sizeof(double) > kDenseExtensionBytes) return nullptr;
  const BandLaplacianFactor factor(g);
  if (!factor.ok()) return nullptr;
  std::vector<int> column_of(size_t(g.node_count), -1);
  for (size_t j = 0; j < sources.size(); ++j) column_of[size_t(sources[j])] = int(j);
  auto op = std::make_shared<BandExtensionOperator>();
  op->band_count = n;
  op->columns.assign(sources.size() * size_t(n), 0.0);
  // Column j of B: 1 at each band node per slot naming source j (the extension's right-hand side).
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < 6; ++d)
      if (const int v = g.band_neighbors[6 * size_t(i) + size_t(d)]; v <= -2)
        op->columns[size_t(column_of[size_t(-v - 2)]) * size_t(n) + size_t(i)] += 1.0;
  const int count = int(sources.size());
#pragma omp parallel for schedule(dynamic)
  for (int first = 0; first < count; first += kColumnsPerSolve) {
    const int k = std::min(kColumnsPerSolve, count - first);
    double* block = op->columns.data() + size_t(first) * size_t(n);
    const std::vector<double> rhs(block, block + size_t(k) * size_t(n));
    factor.solve_columns(k, rhs.data(), block);
  }
  op->sources = std::move(sources);
  return op;
}

}  // namespace

std::shared_ptr<const BandExtensionOperator> band_extension_operator(const StaticArrays& g) {
  if (g.band_count <= 0 || g.band_count > kDirectBandNodes) return nullptr;
  static std::mutex mutex;
  struct Entry {
    std::vector<int> neighbors, degree;
    std::shared_ptr<const BandExtensionOperator> op;
  };
  static std::map<std::uint64_t, Entry> cache;
  static std::vector<std::uint64_t> order;
  const std::uint64_t key = incidence_key(g);
  std::lock_guard<std::mutex> lock(mutex);
  if (auto it = cache.find(key); it != cache.end()) {
    if (it->second.neighbors == g.band_neighbors && it->second.degree == g.band_degree) return it->second.op;
    return build(g);  // another grid with the same key: not cached
  }
  std::shared_ptr<const BandExtensionOperator> op = build(g);
  if (order.size() == kCachedOperators) {
    cache.erase(order.front());
    order.erase(order.begin());
  }
  cache[key] = Entry{g.band_neighbors, g.band_degree, op};
  order.push_back(key);
  return op;
}

}  // namespace ssc
