// SSC_DUMP_NEWMARK_SYSTEM=FOLDER[:K,K,...] writes the Newmark system of the CPU interpreter's
// solves number K (0, 1, ... in this process; default 0), batch item 0, to
// FOLDER/newmark-K.bin for tools/profile/preconditioner_study.cpp: the matrix assembled column
// by column from the matrix-free operator, the right-hand side, the initial guess, the fixed
// mask and the nodes' rest positions. A research aid for the solver (docs/benchmarks.md): each
// dump costs one operator application per unknown.
//
// File layout (little-endian): int64 node count N, int64 nonzero count Z, int64 0; double h;
// double rest[3N]; per unknown (3N) double rhs, guess, fixed (0/1); int64 rows[Z]; int64
// cols[Z]; double values[Z].
#pragma once
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "runtime/static_arrays.h"

namespace ssc {

// Whether this process's solve number k (counted by the call) is to be dumped, and where.
inline bool system_dump_wanted(std::string* folder, int* k) {
  static const char* asked = std::getenv("SSC_DUMP_NEWMARK_SYSTEM");
  static std::atomic<int> solves{0};
  if (!asked || !*asked) return false;
  *k = solves++;
  std::string which = "0";
  *folder = asked;
  if (const size_t colon = folder->find(':'); colon != std::string::npos)
    which = folder->substr(colon + 1), folder->resize(colon);
  for (size_t at = 0; at <= which.size();) {
    const size_t comma = std::min(which.find(',', at), which.size());
    if (std::atoi(which.substr(at, comma - at).c_str()) == *k) return true;
    at = comma + 1;
  }
  return false;
}

// apply(p, q, corner scratch) is the system's operator; is_fixed(node) its fixed mask.
template <class Real, class IsFixed, class Apply>
void dump_system_if_asked(const StaticArrays& g, const Real* rhs, const Real* guess, IsFixed&& is_fixed, Apply&& apply) {
  std::string folder;
  int k = 0;
  if (!system_dump_wanted(&folder, &k)) return;
  const long n = 3L * g.node_count;
  std::vector<Real> p(static_cast<size_t>(n), Real(0)), q(static_cast<size_t>(n)), corner(24 * size_t(g.cell_count));
  std::vector<std::int64_t> rows, cols;
  std::vector<double> values;
  for (long j = 0; j < n; ++j) {
    p[size_t(j)] = Real(1);
    apply(p.data(), q.data(), corner);
    p[size_t(j)] = Real(0);
    for (long i = 0; i < n; ++i)
      if (q[size_t(i)] != Real(0)) rows.push_back(i), cols.push_back(j), values.push_back(double(q[size_t(i)]));
  }
  const std::string path = folder + "/newmark-" + std::to_string(k) + ".bin";
  std::ofstream out(path, std::ios::binary);
  auto put = [&](const void* data, size_t bytes) { out.write(static_cast<const char*>(data), std::streamsize(bytes)); };
  const std::int64_t header[3] = {g.node_count, std::int64_t(values.size()), 0};
  put(header, sizeof header);
  put(&g.h, sizeof g.h);
  put(g.node_rest.data(), g.node_rest.size() * sizeof(double));
  for (long i = 0; i < n; ++i) {
    const double v[3] = {double(rhs[i]), double(guess[i]), is_fixed(int(i / 3)) ? 1.0 : 0.0};
    put(v, sizeof v);
  }
  put(rows.data(), rows.size() * sizeof(std::int64_t));
  put(cols.data(), cols.size() * sizeof(std::int64_t));
  put(values.data(), values.size() * sizeof(double));
  if (!out) throw std::runtime_error("SSC_DUMP_NEWMARK_SYSTEM: cannot write " + path);
}

}  // namespace ssc
