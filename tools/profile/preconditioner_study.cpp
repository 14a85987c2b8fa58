// How many CG iterations a time step's Newmark solve needs under other preconditioners than
// the engine's Jacobi (issue 27: the step is ~95 % CG iterations). Reads systems written by
// SSC_DUMP_NEWMARK_SYSTEM (runtime/system_dump.h), assembles them as sparse matrices and runs
// PCG from the engine's initial guess to the engine's tolerance (||r|| <= tol ||b||) with:
//   - Jacobi (the engine's; its count must match the engine's report for the step),
//   - a Chebyshev-accelerated Jacobi polynomial of degree k (k - 1 operator products a CG
//     iteration) on [lambda_max / ratio, lambda_max] of D^-1 A,
//   - geometric multigrid V(nu, nu) cycles on the cell grid: coarse nodes every 2^l cells,
//     trilinear prolongation P, Galerkin coarse matrices P^T A P, damped Jacobi smoothing and
//     a direct solve on the coarsest level;
//   - two levels added instead (D^-1 r + P A_c^-1 P^T r, coarse nodes every 2 to 16 cells).
// With --frozen, built once from the first file's matrix and used for every file instead:
// its LDL^T factor, its scalar (per-component) factor, and two levels with its coarse factor;
// with the solve and factorization times.
// Each line gives the iterations and their cost in fine-grid operator applications (a CG
// iteration 1, a V-cycle 2 nu + 1 on the finest level plus an eighth of that per level below).
// With --forms, Jacobi PCG alone in the engine's, the GPU's and a pipelined order (jacobi_cg_form).
// With --boxes, block Jacobi on boxes of grid nodes (BoxJacobi: the exact inverse of A's block on
// each box), a preconditioner a GPU block could apply from its own shared memory.
// Usage: ssc_preconditioner_study FILE... [--tol 1e-6] [--frozen | --forms | --boxes]
#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

namespace {

using Sparse = Eigen::SparseMatrix<double>;
using Vector = Eigen::VectorXd;

struct System {
  int nodes = 0;
  double h = 0;
  std::vector<double> rest;  // 3 per node
  Vector rhs, guess;
  std::vector<bool> fixed;  // per dof
  Sparse A;
};

System read_system(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  auto get = [&](void* data, size_t bytes) {
    in.read(static_cast<char*>(data), std::streamsize(bytes));
    if (!in) throw std::runtime_error(path + ": truncated");
  };
  std::int64_t header[3];
  get(header, sizeof header);
  System s;
  s.nodes = int(header[0]);
  const long n = 3L * s.nodes, nnz = long(header[1]);
  get(&s.h, sizeof s.h);
  s.rest.resize(size_t(n));
  get(s.rest.data(), s.rest.size() * sizeof(double));
  s.rhs.resize(n), s.guess.resize(n), s.fixed.resize(size_t(n));
  for (long i = 0; i < n; ++i) {
    double v[3];
    get(v, sizeof v);
    s.rhs[i] = v[2] != 0 ? 0 : v[0], s.guess[i] = v[2] != 0 ? 0 : v[1], s.fixed[size_t(i)] = v[2] != 0;
  }
  std::vector<std::int64_t> rows(static_cast<size_t>(nnz)), cols(static_cast<size_t>(nnz));
  std::vector<double> values(static_cast<size_t>(nnz));
  get(rows.data(), rows.size() * sizeof(std::int64_t));
  get(cols.data(), cols.size() * sizeof(std::int64_t));
  get(values.data(), values.size() * sizeof(double));
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(size_t(nnz));
  for (long k = 0; k < nnz; ++k) t.emplace_back(int(rows[size_t(k)]), int(cols[size_t(k)]), values[size_t(k)]);
  s.A.resize(int(n), int(n));
  s.A.setFromTriplets(t.begin(), t.end());
  return s;
}

// Preconditioned CG as the engine runs it; returns the iterations (max_iterations + 1 if not
// converged).
int pcg(const Sparse& A, const Vector& b, Vector x, const std::function<Vector(const Vector&)>& precondition, double tol,
        int max_iterations) {
  Vector r = b - A * x;
  const double stop = tol * b.norm();
  if (r.norm() <= stop) return 0;
  Vector z = precondition(r), p = z;
  double rz = r.dot(z);
  for (int it = 1; it <= max_iterations; ++it) {
    const Vector q = A * p;
    const double alpha = rz / p.dot(q);
    x += alpha * p;
    r -= alpha * q;
    if (r.norm() <= stop) return it;
    z = precondition(r);
    const double rz_new = r.dot(z);
    p = z + (rz_new / rz) * p;
    rz = rz_new;
  }
  return max_iterations + 1;
}

// Iterations of PCG preconditioned by Jacobi, the engine's solve.
int jacobi_pcg_iterations(const System& s, const Vector& inv_diag, double tol, int max_iterations) {
  return pcg(s.A, s.rhs, s.guess, [&](const Vector& r) { return Vector(inv_diag.cwiseProduct(r)); }, tol,
             max_iterations);
}

// The Jacobi-PCG iterates in three orders of the same recurrences: the engine's (pcg above), the
// GPU's Chronopoulos-Gear form (one reduction an iteration, the sums gamma = r.u, delta = (A u).u
// and |r|^2 after the operator product) and the pipelined form of Ghysels and Vanroose (2014),
// whose reduction is needed only after the next operator product (m = M^-1 w, n = A m), so it
// could travel while that product runs. Each stops on its recurrence's |r| <= tol |b|; returns
// the iterations and, in true_rel, |b - A x| / |b| at the stop.
enum class CgForm { ChronopoulosGear, Pipelined };
// In T (float: the vectors and products in float, the sums in double, as on the GPU).
template <class T>
int jacobi_cg_form(CgForm form, const Sparse& A_double, const Vector& b_double, const Vector& x_double,
                   const Vector& inv_diag_double, double tol, int max_iterations, double* true_rel) {
  using V = Eigen::Matrix<T, Eigen::Dynamic, 1>;
  const Eigen::SparseMatrix<T> A = A_double.cast<T>();
  const V b = b_double.cast<T>(), inv_diag = inv_diag_double.cast<T>();
  auto dot = [](const V& a, const V& c) { return a.template cast<double>().dot(c.template cast<double>()); };
  const double b_norm = b_double.norm(), stop = tol * b_norm;
  V x = x_double.cast<T>();
  V r = b - A * x, u = inv_diag.cwiseProduct(r), w = A * u;
  V p = V::Zero(b.size()), s = p, q = p, z = p;
  double gamma_old = 0, alpha = 0;
  int it = 0;
  for (;; ++it) {
    const double gamma = dot(r, u), delta = dot(w, u), rr = dot(r, r);
    if (std::sqrt(rr) <= stop || it > max_iterations) break;
    const double beta = it == 0 ? 0.0 : gamma / gamma_old;
    alpha = it == 0 ? gamma / delta : gamma / (delta - beta * gamma / alpha);
    gamma_old = gamma;
    const T a = T(alpha), c = T(beta);
    if (form == CgForm::Pipelined) {
      const V m = inv_diag.cwiseProduct(w), n = A * m;
      z = n + c * z;
      q = m + c * q;
      s = w + c * s;
      p = u + c * p;
      x += a * p;
      r -= a * s;
      u -= a * q;
      w -= a * z;
    } else {
      p = u + c * p;
      s = w + c * s;
      x += a * p;
      r -= a * s;
      u = inv_diag.cwiseProduct(r);
      w = A * u;
    }
  }
  *true_rel = (b_double - A_double * x.template cast<double>()).norm() / b_norm;
  return it;
}

// The largest eigenvalue of D^-1 A by power iteration.
double largest_jacobi_eigenvalue(const Sparse& A, const Vector& inv_diag) {
  Vector v = Vector::Ones(A.rows()).normalized();
  double lambda = 0;
  for (int i = 0; i < 50; ++i) {
    const Vector w = inv_diag.cwiseProduct(A * v);
    lambda = v.dot(w);
    v = w.normalized();
  }
  return lambda;
}

// The Chebyshev-accelerated Jacobi polynomial of degree `degree` for D^-1 A on
// [lambda_max / ratio, lambda_max] applied to r: a fixed linear operator p(D^-1 A) D^-1,
// symmetric and (for eigenvalues below lambda_max) positive, so CG can take it as a
// preconditioner; degree - 1 products with A.
Vector chebyshev(const Sparse& A, const Vector& inv_diag, double lambda_max, double ratio, int degree, const Vector& r) {
  const double lo = lambda_max / ratio, theta = (lambda_max + lo) / 2, delta = (lambda_max - lo) / 2;
  const double sigma = theta / delta;
  const Vector f = inv_diag.cwiseProduct(r);
  Vector d = f / theta, z = d;
  double rho = 1 / sigma;
  for (int i = 1; i < degree; ++i) {
    const double rho_next = 1 / (2 * sigma - rho);
    const Vector res = f - inv_diag.cwiseProduct(A * z);
    d = rho_next * rho * d + (2 * rho_next / delta) * res;
    z += d;
    rho = rho_next;
  }
  return z;
}

struct Level {
  Sparse A, P;  // P: from the next coarser level to this one (empty on the coarsest)
  Vector inv_diag;
  std::vector<std::array<long, 3>> coords;  // per node, in units of this level's spacing
  std::unique_ptr<Eigen::SimplicialLDLT<Sparse>> direct;
};

// The nodes of the next coarser level and the trilinear prolongation to `fine`'s nodes.
Sparse prolongation(const Level& fine, const std::vector<bool>& fixed, std::vector<std::array<long, 3>>* coarse_coords) {
  std::map<std::array<long, 3>, int> index;
  std::vector<Eigen::Triplet<double>> t;
  const int nodes = int(fine.coords.size());
  for (int i = 0; i < nodes; ++i) {
    if (fixed.size() && fixed[size_t(3 * i)]) continue;
    const auto& c = fine.coords[size_t(i)];
    std::vector<std::pair<long, double>> axis[3];
    for (int a = 0; a < 3; ++a) {
      const long lo = c[size_t(a)] >= 0 ? c[size_t(a)] / 2 : -((-c[size_t(a)] + 1) / 2);
      if (c[size_t(a)] == 2 * lo)
        axis[a] = {{lo, 1.0}};
      else
        axis[a] = {{lo, 0.5}, {lo + 1, 0.5}};
    }
    for (const auto& [x, wx] : axis[0])
      for (const auto& [y, wy] : axis[1])
        for (const auto& [z, wz] : axis[2]) {
          const std::array<long, 3> key{x, y, z};
          auto [at, added] = index.emplace(key, int(index.size()));
          if (added) coarse_coords->push_back(key);
          for (int d = 0; d < 3; ++d) t.emplace_back(3 * i + d, 3 * at->second + d, wx * wy * wz);
        }
  }
  Sparse P(3 * nodes, 3 * int(index.size()));
  P.setFromTriplets(t.begin(), t.end());
  return P;
}

struct Multigrid {
  std::vector<Level> levels;
  int nu = 2;
  double omega = 0.6;
  double cost = 0;  // fine-operator applications per cycle

  Multigrid(const System& s, int nu_, double omega_, int direct_below) : nu(nu_), omega(omega_) {
    Level fine;
    fine.A = s.A;
    double lo[3] = {1e300, 1e300, 1e300};
    for (int i = 0; i < s.nodes; ++i)
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], s.rest[size_t(3 * i + a)]);
    for (int i = 0; i < s.nodes; ++i) {
      std::array<long, 3> c;
      for (int a = 0; a < 3; ++a) c[size_t(a)] = std::lround((s.rest[size_t(3 * i + a)] - lo[a]) / s.h);
      fine.coords.push_back(c);
    }
    levels.push_back(std::move(fine));
    while (levels.back().A.rows() > direct_below) {
      Level& f = levels.back();
      Level coarse;
      f.P = prolongation(f, levels.size() == 1 ? s.fixed : std::vector<bool>{}, &coarse.coords);
      coarse.A = Sparse(f.P.transpose() * f.A * f.P);
      if (coarse.A.rows() >= f.A.rows()) break;
      levels.push_back(std::move(coarse));
    }
    double share = 1;
    for (size_t l = 0; l < levels.size(); ++l) {
      Level& L = levels[l];
      L.inv_diag = L.A.diagonal().cwiseInverse();
      if (l + 1 == levels.size()) {
        L.direct = std::make_unique<Eigen::SimplicialLDLT<Sparse>>(L.A);
        if (L.direct->info() != Eigen::Success) throw std::runtime_error("coarsest level not factorised");
      } else {
        cost += share * (2 * nu + 1);
      }
      share *= double(levels[std::min(l + 1, levels.size() - 1)].A.rows()) / double(L.A.rows());
    }
  }

  Vector cycle(size_t l, const Vector& b) const {
    const Level& L = levels[l];
    if (L.direct) return L.direct->solve(b);
    Vector x = Vector::Zero(b.size());
    for (int k = 0; k < nu; ++k) x += omega * L.inv_diag.cwiseProduct(b - L.A * x);
    const Vector r = b - L.A * x;
    x += L.P * cycle(l + 1, L.P.transpose() * r);
    for (int k = 0; k < nu; ++k) x += omega * L.inv_diag.cwiseProduct(b - L.A * x);
    return x;
  }
};

// Two levels added, not multiplied: z = D^-1 r + P A_c^-1 P^T r with coarse nodes every 2^l
// cells (l trilinear prolongations in a row), A_c = P^T A P factored. No smoothing sweeps: a
// CG iteration costs one fine product, a restriction, a coarse solve and a prolongation,
// which a persistent GPU solve can fold into its node update and the reduction's barrier.
struct AdditiveTwoLevel {
  Sparse P;
  Vector inv_diag;
  std::unique_ptr<Eigen::SimplicialLDLT<Sparse>> coarse;

  AdditiveTwoLevel(const System& s, int l) {
    const Multigrid grid(s, 1, 0.7, 0);  // every level down to one node; only the prolongations are used
    P = grid.levels[0].P;
    for (int k = 1; k < l && size_t(k) + 1 < grid.levels.size(); ++k) P = Sparse(P * grid.levels[size_t(k)].P);
    inv_diag = s.A.diagonal().cwiseInverse();
    coarse = std::make_unique<Eigen::SimplicialLDLT<Sparse>>(Sparse(P.transpose() * s.A * P));
    if (coarse->info() != Eigen::Success) throw std::runtime_error("coarse matrix not factorised");
  }
  Vector apply(const Vector& r) const {
    return Vector(inv_diag.cwiseProduct(r)) + P * coarse->solve(Vector(P.transpose() * r));
  }
};

}  // namespace

// The nodes grouped into boxes of bx x by x bz grid nodes (from the rest positions); M^-1 r is
// the exact solve with A's diagonal block of each box's dofs, boxes apart (non-overlapping
// block Jacobi; bx = by = bz = 1 is the 3x3 node-block Jacobi).
struct BoxJacobi {
  std::vector<std::vector<long>> dofs;  // per box
  std::vector<int> box;                 // per dof
  std::vector<Eigen::LDLT<Eigen::MatrixXd>> blocks;
  BoxJacobi(const System& s, int bx, int by, int bz) {
    double lo[3] = {1e300, 1e300, 1e300};
    for (int i = 0; i < s.nodes; ++i)
      for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], s.rest[3 * size_t(i) + d]);
    std::map<std::tuple<long, long, long>, int> box_of;
    const int size[3] = {bx, by, bz};
    for (int i = 0; i < s.nodes; ++i) {
      long key[3];
      for (int d = 0; d < 3; ++d) key[d] = std::lround((s.rest[3 * size_t(i) + d] - lo[d]) / s.h) / size[d];
      const auto it = box_of.emplace(std::make_tuple(key[0], key[1], key[2]), int(dofs.size())).first;
      if (it->second == int(dofs.size())) dofs.emplace_back();
      for (int d = 0; d < 3; ++d) dofs[size_t(it->second)].push_back(3L * i + d);
    }
    box.resize(size_t(3 * s.nodes));
    std::vector<int> local(size_t(3 * s.nodes));
    for (size_t b = 0; b < dofs.size(); ++b)
      for (size_t k = 0; k < dofs[b].size(); ++k) box[size_t(dofs[b][k])] = int(b), local[size_t(dofs[b][k])] = int(k);
    std::vector<Eigen::MatrixXd> dense(dofs.size());
    for (size_t b = 0; b < dofs.size(); ++b) {
      const long m = long(dofs[b].size());
      dense[b] = Eigen::MatrixXd::Zero(m, m);
    }
    for (int k = 0; k < s.A.outerSize(); ++k)
      for (Sparse::InnerIterator e(s.A, k); e; ++e)
        if (box[size_t(e.row())] == box[size_t(e.col())])
          dense[size_t(box[size_t(e.row())])](local[size_t(e.row())], local[size_t(e.col())]) = e.value();
    for (const Eigen::MatrixXd& m : dense) blocks.emplace_back(m);
  }
  // A without its couplings between boxes: the block diagonal the exact solve inverts.
  Sparse block_diagonal(const Sparse& A) const {
    std::vector<Eigen::Triplet<double>> t;
    for (int k = 0; k < A.outerSize(); ++k)
      for (Sparse::InnerIterator e(A, k); e; ++e)
        if (box[size_t(e.row())] == box[size_t(e.col())]) t.emplace_back(int(e.row()), int(e.col()), e.value());
    Sparse B(A.rows(), A.cols());
    B.setFromTriplets(t.begin(), t.end());
    return B;
  }
  size_t largest() const {
    size_t m = 0;
    for (const auto& d : dofs) m = std::max(m, d.size());
    return m;
  }
  Vector apply(const Vector& r) const {
    Vector z(r.size());
    for (size_t b = 0; b < dofs.size(); ++b) {
      Eigen::VectorXd rb(long(dofs[b].size()));
      for (size_t k = 0; k < dofs[b].size(); ++k) rb[long(k)] = r[dofs[b][k]];
      const Eigen::VectorXd zb = blocks[b].solve(rb);
      for (size_t k = 0; k < dofs[b].size(); ++k) z[dofs[b][k]] = zb[long(k)];
    }
    return z;
  }
};

int main(int argc, char** argv) {
  std::vector<std::string> files;
  double tol = 1e-6;
  bool frozen = false, forms = false, boxes = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--frozen")
      frozen = true;
    else if (a == "--forms")
      forms = true;
    else if (a == "--boxes")
      boxes = true;
    else if (a == "--tol" && i + 1 < argc)
      tol = std::atof(argv[++i]);
    else
      files.push_back(a);
  }
  if (files.empty()) {
    std::fprintf(stderr, "usage: ssc_preconditioner_study FILE... [--tol 1e-6] [--frozen | --forms | --boxes] (files from "
                         "SSC_DUMP_NEWMARK_SYSTEM)\n");
    return 2;
  }
  if (forms) {
    for (const std::string& f : files) {
      const System s = read_system(f);
      const Vector inv_diag = s.A.diagonal().cwiseInverse();
      const int engine = jacobi_pcg_iterations(s, inv_diag, tol, 20000);
      std::printf("%s: Jacobi PCG %d iterations", f.c_str(), engine);
      for (const bool single : {false, true})
        for (const CgForm form : {CgForm::ChronopoulosGear, CgForm::Pipelined}) {
          double rel = 0;
          const int it = single ? jacobi_cg_form<float>(form, s.A, s.rhs, s.guess, inv_diag, tol, 20000, &rel)
                                : jacobi_cg_form<double>(form, s.A, s.rhs, s.guess, inv_diag, tol, 20000, &rel);
          std::printf("; %s %s %d (true residual %.2e of |b|)", single ? "float" : "double",
                      form == CgForm::Pipelined ? "pipelined" : "Chronopoulos-Gear", it, rel);
        }
      std::printf("\n");
    }
    return 0;
  }
  if (boxes) {
    for (const std::string& f : files) {
      const System s = read_system(f);
      const Vector inv_diag = s.A.diagonal().cwiseInverse();
      std::printf("%s: Jacobi %d", f.c_str(), jacobi_pcg_iterations(s, inv_diag, tol, 20000));
      const std::vector<std::array<int, 3>> sizes = {{1, 1, 1}, {2, 2, 2}, {2, 2, 4}, {2, 4, 4},
                                                     {3, 3, 3}, {4, 4, 4}, {4, 4, 8}};
      for (const auto& b : sizes) {
        const BoxJacobi M(s, b[0], b[1], b[2]);
        std::printf("; boxes %dx%dx%d (%zu, largest %zu dofs) %d", b[0], b[1], b[2], M.dofs.size(), M.largest(),
                    pcg(s.A, s.rhs, s.guess, [&](const Vector& r) { return M.apply(r); }, tol, 20000));
      }
      std::printf("\n");
      // The boxes' solves inexact: a Chebyshev-Jacobi polynomial of the block diagonal (its
      // products need no values from other boxes).
      for (const auto& b : std::vector<std::array<int, 3>>{{2, 2, 2}, {2, 2, 4}, {4, 4, 4}}) {
        const BoxJacobi M(s, b[0], b[1], b[2]);
        const Sparse B = M.block_diagonal(s.A);
        const double lambda_max = 1.05 * largest_jacobi_eigenvalue(B, inv_diag);
        std::printf("  boxes %dx%dx%d, Chebyshev-Jacobi of the block diagonal:", b[0], b[1], b[2]);
        for (const int degree : {2, 3, 4, 8})
          for (const double ratio : {10.0, 30.0})
            std::printf(" degree %d ratio %.0f %d;", degree, ratio,
                        pcg(s.A, s.rhs, s.guess,
                            [&](const Vector& r) { return chebyshev(B, inv_diag, lambda_max, ratio, degree, r); }, tol,
                            20000));
        std::printf("\n");
      }
    }
    return 0;
  }
  if (frozen) {
    // A factor of the first file's matrix as every file's preconditioner (one triangular pair a
    // CG iteration): how far a factor built once carries over later steps' rotations and contact.
    const System first = read_system(files[0]);
    Eigen::SimplicialLDLT<Sparse> factor(first.A);
    if (factor.info() != Eigen::Success) throw std::runtime_error("first matrix not factorised");
    std::printf("factor of %s: %ld nonzeros in L (A: %ld)\n", files[0].c_str(), long(factor.matrixL().nestedExpression().nonZeros()),
                long(first.A.nonZeros()));
    // The same for a scalar matrix: the average of each node pair's three diagonal entries,
    // factored once and solved per component (rotation-invariant: R (S x I3) R^T = S x I3).
    const int nodes = first.nodes;
    std::vector<Eigen::Triplet<double>> st;
    for (int k = 0; k < first.A.outerSize(); ++k)
      for (Sparse::InnerIterator e(first.A, k); e; ++e)
        if (e.row() % 3 == e.col() % 3) st.emplace_back(int(e.row() / 3), int(e.col() / 3), e.value() / 3);
    Sparse S(nodes, nodes);
    S.setFromTriplets(st.begin(), st.end());
    Eigen::SimplicialLDLT<Sparse> scalar(S);
    std::printf("scalar factor: %ld nonzeros in L\n", long(scalar.matrixL().nestedExpression().nonZeros()));
    auto componentwise = [&](const Vector& r) {
      Vector z(r.size());
      Vector c(nodes);
      for (int d = 0; d < 3; ++d) {
        for (int i = 0; i < nodes; ++i) c[i] = r[3 * i + d];
        c = scalar.solve(c);
        for (int i = 0; i < nodes; ++i) z[3 * i + d] = c[i];
      }
      return z;
    };
    auto seconds = [](const std::function<void()>& f) {
      const auto t0 = std::chrono::steady_clock::now();
      for (int k = 0; k < 50; ++k) f();
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / 50;
    };
    Vector probe = Vector::Ones(3 * nodes);
    std::printf("a factorization: full %.1f ms, scalar %.2f ms\n", 1e3 * seconds([&] { factor.compute(first.A); }),
                1e3 * seconds([&] { scalar.compute(S); }));
    std::printf("a solve: full %.3f ms, componentwise %.3f ms, an A product %.3f ms\n",
                1e3 * seconds([&] { probe = factor.solve(probe).normalized(); }),
                1e3 * seconds([&] { probe = componentwise(probe).normalized(); }),
                1e3 * seconds([&] { probe = (first.A * probe).normalized(); }));
    // Two levels whose coarse factor is the first file's (P^T A P factored once); the fine
    // level's smoothing and residuals use each file's own matrix.
    Multigrid two_level(first, 1, 0.7, 3000);
    std::printf("two levels: %ld coarse unknowns; a coarse solve %.3f ms\n", long(two_level.levels.back().A.rows()),
                1e3 * seconds([&] {
                  Vector c = Vector::Ones(two_level.levels.back().A.rows());
                  c = two_level.levels.back().direct->solve(c);
                }));
    for (const std::string& f : files) {
      const System s = read_system(f);
      const Vector inv_diag = s.A.diagonal().cwiseInverse();
      two_level.levels[0].A = s.A;
      two_level.levels[0].inv_diag = inv_diag;
      std::printf("%s: two levels V(1,1), the first file's coarse factor: %d; ", f.c_str(),
                  pcg(s.A, s.rhs, s.guess, [&](const Vector& r) { return two_level.cycle(0, r); }, tol, 2000));
      const int cw = pcg(s.A, s.rhs, s.guess, componentwise, tol, 2000);
      std::printf("%s: componentwise %d; ", f.c_str(), cw);
      const int jacobi = jacobi_pcg_iterations(s, inv_diag, tol, 2000);
      const int it = pcg(s.A, s.rhs, s.guess, [&](const Vector& r) { return Vector(factor.solve(r)); }, tol, 2000);
      std::printf("%s: Jacobi %d iterations; the first file's factor %d\n", f.c_str(), jacobi, it);
    }
    return 0;
  }
  for (const std::string& f : files) {
    const System s = read_system(f);
    const Vector inv_diag = s.A.diagonal().cwiseInverse();
    const int jacobi = jacobi_pcg_iterations(s, inv_diag, tol, 2000);
    std::printf("%s: %d nodes, %ld nonzeros; Jacobi PCG %d iterations (cost %d)\n", f.c_str(), s.nodes, long(s.A.nonZeros()),
                jacobi, jacobi);
    const double lambda_max = 1.05 * largest_jacobi_eigenvalue(s.A, inv_diag);
    for (const int degree : {2, 3, 4, 6, 8})
      for (const double ratio : {10.0, 30.0, 100.0}) {
        const int it = pcg(s.A, s.rhs, s.guess,
                           [&](const Vector& r) { return chebyshev(s.A, inv_diag, lambda_max, ratio, degree, r); }, tol, 2000);
        std::printf("  Chebyshev-Jacobi degree %d on [lambda_max / %.0f, lambda_max] (lambda_max %.3g): %d iterations "
                    "(cost %d; with its inner products at half cost %.0f)\n",
                    degree, ratio, lambda_max, it, it * degree, it * (1 + 0.5 * (degree - 1)));
      }
    for (const int l : {1, 2, 3, 4}) {
      const AdditiveTwoLevel two(s, l);
      const int it = pcg(s.A, s.rhs, s.guess, [&](const Vector& r) { return two.apply(r); }, tol, 2000);
      std::printf("  additive two levels, coarse nodes every %d cells (%ld unknowns): %d iterations\n", 1 << l,
                  long(two.P.cols()), it);
    }
    for (const int direct_below : {3000, 600})
      for (const int nu : {1, 2, 3})
        for (const double omega : {0.5, 0.7}) {
          const Multigrid mg(s, nu, omega, direct_below);
          const int it = pcg(s.A, s.rhs, s.guess, [&](const Vector& r) { return mg.cycle(0, r); }, tol, 2000);
          std::string sizes;
          for (const Level& L : mg.levels) sizes += (sizes.empty() ? "" : "/") + std::to_string(L.A.rows());
          std::printf("  multigrid V(%d,%d) omega %.1f, %zu levels (%s unknowns): %d iterations (cost %.0f)\n", nu, nu,
                      omega, mg.levels.size(), sizes.c_str(), it, it * (1 + mg.cost));
        }
  }
  return 0;
}
