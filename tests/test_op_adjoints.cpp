// Adjoints of the op bodies in ops/ (level ii of the test pyramid, docs/decisions.md E3) and
// the implicit ops' properties (level iv; docs/decisions.md E1 and E2).
//
// OpAdjoint*: for every op with an adj_ function, on random physically sensible inputs
// and several seeds, in double:
//   - dot-product test: the forward body instantiated with Dual<double> (graph/dual.h),
//     seeded with a random direction x_dot on every differentiable input, gives J x_dot;
//     the adj_ function gives J^T y_bar for a random y_bar; <J x_dot, y_bar> must equal
//     <x_dot, J^T y_bar> (1e-12 relative; 1e-10 for the trilinear inverse, whose Dual
//     forward differentiates the Newton iterations, stopped at a residual of 1e-13 h,
//     while the adjoint is implicit: see ImplicitTrilinear for how the gap depends on
//     the stopping point);
//   - central finite differences of the double forward along the same x_dot (step 1e-6
//     relative to each input's scale) against J x_dot and against <x_dot, J^T y_bar>;
//   - the adj_ functions accumulate (+=) into their bar arguments.
// Implicit*: the trilinear inverse and the polar rotation do not depend on their
// iteration's initial guess (converged result, Dual derivative with respect to the start
// and adjoint all independent of it to round-off), the implicit adjoint agrees with
// differentiating the converged iterations, and the linear-solve adjoint identity
// (b_bar = A^-1 x_bar, p_bar = -lambda^T dA/dp x) on the dense Newmark matrix of one cell.
//
// The measured errors are printed (a table per op); the report quotes them.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "ops/contact.h"
#include "ops/elasticity.h"
#include "ops/newmark.h"
#include "ops/nodal.h"
#include "ops/polar.h"
#include "ops/ssc_math.h"
#include "ops/trilinear.h"
#include "graph/dual.h"

namespace ssc {
namespace {

using D = Dual<double>;
using Rng = std::mt19937_64;

static_assert(sizeof(Dual<double>) != 4, "ops/polar.h picks its tolerance by sizeof(Real) == 4");

double uni(Rng& r, double a, double b) { return std::uniform_real_distribution<double>(a, b)(r); }

double dotv(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}
double normv(const std::vector<double>& a) { return std::sqrt(dotv(a, a)); }

// ---- flat <-> Vec3 / Mat3 helpers (row-major matrices) ----
template <class R>
Vec3<R> get3(const std::vector<R>& x, size_t o) {
  return {x[o], x[o + 1], x[o + 2]};
}
template <class R>
Mat3<R> get33(const std::vector<R>& x, size_t o) {
  Mat3<R> M;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) M.m[i][j] = x[o + 3 * i + j];
  return M;
}
template <class R>
void put3(std::vector<R>& y, Vec3<R> v) {
  y.push_back(v.x), y.push_back(v.y), y.push_back(v.z);
}
template <class R>
void put33(std::vector<R>& y, const Mat3<R>& M) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) y.push_back(M.m[i][j]);
}
Mat3<double> mat_at(const std::vector<double>& x, size_t o) { return get33(x, o); }
void store_mat(std::vector<double>& x, size_t o, const Mat3<double>& M) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) x[o + 3 * i + j] = M.m[i][j];
}
void store_vec(std::vector<double>& x, size_t o, Vec3<double> v) { x[o] = v.x, x[o + 1] = v.y, x[o + 2] = v.z; }

template <class R>
Mat3<R> to(const Mat3<double>& M) {
  Mat3<R> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = R(M.m[i][j]);
  return r;
}
template <class R>
Vec3<R> to(Vec3<double> v) {
  return {R(v.x), R(v.y), R(v.z)};
}

// The Newton stop of the trilinear inverse: the case's (1e-13 h) in double; float cannot
// reach it, so there the float-vs-double check stops where float rounding does.
template <class R>
R newton_tolerance(double tol) {
  return sizeof(R) == 4 ? R(tol * 1e7) : R(tol);
}

// ---- random physically sensible inputs ----
Mat3<double> random_rotation(Rng& rng) {
  std::normal_distribution<double> n(0, 1);
  double q[4], s = 0;
  for (double& v : q) v = n(rng), s += v * v;
  s = std::sqrt(s);
  const double w = q[0] / s, x = q[1] / s, y = q[2] / s, z = q[3] / s;
  Mat3<double> R;
  R.m[0][0] = 1 - 2 * (y * y + z * z), R.m[0][1] = 2 * (x * y - z * w), R.m[0][2] = 2 * (x * z + y * w);
  R.m[1][0] = 2 * (x * y + z * w), R.m[1][1] = 1 - 2 * (x * x + z * z), R.m[1][2] = 2 * (y * z - x * w);
  R.m[2][0] = 2 * (x * z - y * w), R.m[2][1] = 2 * (y * z + x * w), R.m[2][2] = 1 - 2 * (x * x + y * y);
  return R;
}

// F = Q (I + s G): a rotation times a stretch of relative size s (det F kept well positive).
Mat3<double> random_deformation_gradient(Rng& rng, double s) {
  for (;;) {
    Mat3<double> G = identity3<double>();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) G.m[i][j] += s * uni(rng, -1, 1);
    const Mat3<double> F = random_rotation(rng) * G;
    if (det(F) > 0.3) return F;
  }
}

struct Material {
  double lambda, mu;
};
Material random_material(Rng& rng) {
  Material m;
  ops::lame_from_young(uni(rng, 1e3, 1e5), uni(rng, 0.2, 0.45), m.lambda, m.mu);
  return m;
}

// Cut-cell volume weights: full weight h^3/8 scaled by (0.05, 1]; with `empty_corner`
// one corner carries no volume (the op skips it).
std::vector<double> random_weights(Rng& rng, double h, bool empty_corner) {
  std::vector<double> w(8);
  for (double& v : w) v = h * h * h / 8 * uni(rng, 0.05, 1.0);
  if (empty_corner) w[std::uniform_int_distribution<int>(0, 7)(rng)] = 0;
  return w;
}

// A mildly deformed, rotated cell of size h (corners X_c, c = bx + 2 by + 4 bz).
std::vector<Vec3<double>> random_cell(Rng& rng, double h) {
  const Mat3<double> Q = random_rotation(rng);
  const Vec3<double> o = make_vec3(uni(rng, -1, 1), uni(rng, -1, 1), uni(rng, -1, 1));
  std::vector<Vec3<double>> X(8);
  for (int c = 0; c < 8; ++c) {
    Vec3<double> local = make_vec3(h * corner_bit(c, 0), h * corner_bit(c, 1), h * corner_bit(c, 2));
    for (int a = 0; a < 3; ++a) local[a] += 0.1 * h * uni(rng, -1, 1);
    X[c] = o + Q * local;
  }
  return X;
}

// ---- the harness ----
struct Metrics {
  double dot = 0;      // |<J x_dot, y_bar> - <x_dot, J^T y_bar>| / max(|.|, |.|)
  double fd = 0;       // |FD - J x_dot| / |J x_dot|
  double fd_vjp = 0;   // |<FD, y_bar> - <x_dot, J^T y_bar>| / |<x_dot, J^T y_bar>|
  double value = 0;    // |Dual value - double forward| / |forward|
  double accumulate = 0;  // |vjp(acc = vjp) - 2 vjp| / |2 vjp|
  double single = 0;      // |float forward - double forward| / |double forward|
};

// A case provides x (differentiable inputs, flattened), scale (per input: the size of a
// sensible perturbation), forward<R>(x) -> y and vjp(y_bar, acc) -> acc + J^T y_bar.
template <class Case>
Metrics check_case(const Case& c, Rng& rng, double eps = 1e-6) {
  const size_t n = c.x.size();
  std::vector<double> xd(n);
  for (size_t i = 0; i < n; ++i) xd[i] = uni(rng, -1, 1) * c.scale[i];
  std::vector<D> xx(n);
  for (size_t i = 0; i < n; ++i) xx[i] = D(c.x[i], xd[i]);
  const std::vector<D> yy = c.template forward<D>(xx);
  const std::vector<double> y = c.template forward<double>(c.x);
  const size_t m = y.size();
  EXPECT_EQ(yy.size(), m);
  std::vector<double> jvp(m), yv(m), yb(m);
  for (size_t i = 0; i < m; ++i) jvp[i] = yy[i].d, yv[i] = yy[i].v, yb[i] = uni(rng, -1, 1);
  Metrics r;
  {
    std::vector<double> diff(m);
    for (size_t i = 0; i < m; ++i) diff[i] = yv[i] - y[i];
    r.value = normv(diff) / std::max(normv(y), 1e-300);
  }
  const std::vector<double> xb = c.vjp(yb, std::vector<double>(n, 0.0));
  const double a = dotv(jvp, yb), b = dotv(xd, xb);
  r.dot = std::abs(a - b) / std::max({std::abs(a), std::abs(b), 1e-300});
  {
    const std::vector<double> xb2 = c.vjp(yb, xb);
    std::vector<double> diff(n);
    for (size_t i = 0; i < n; ++i) diff[i] = xb2[i] - 2 * xb[i];
    r.accumulate = normv(diff) / std::max(2 * normv(xb), 1e-300);
  }
  std::vector<double> xp(n), xm(n);
  for (size_t i = 0; i < n; ++i) xp[i] = c.x[i] + eps * xd[i], xm[i] = c.x[i] - eps * xd[i];
  const std::vector<double> yp = c.template forward<double>(xp), ym = c.template forward<double>(xm);
  std::vector<double> fd(m), diff(m);
  for (size_t i = 0; i < m; ++i) fd[i] = (yp[i] - ym[i]) / (2 * eps), diff[i] = fd[i] - jvp[i];
  r.fd = normv(diff) / std::max(normv(jvp), 1e-300);
  r.fd_vjp = std::abs(dotv(fd, yb) - b) / std::max(std::abs(b), 1e-300);
  {
    const std::vector<float> xf(c.x.begin(), c.x.end());
    const std::vector<float> yf = c.template forward<float>(xf);
    std::vector<double> d(m);
    for (size_t i = 0; i < m; ++i) d[i] = double(yf[i]) - y[i];
    r.single = normv(d) / std::max(normv(y), 1e-300);
  }
  return r;
}

struct Tolerances {
  double dot = 1e-12, fd = 1e-6, value = 1e-15, accumulate = 1e-14, single = 1e-5;
};

// Every checked part with its worst errors and limits, printed as one table when the test
// binary ends (`build/bin/ssc_tests --gtest_filter='OpAdjoint*'` prints the op check table).
struct CheckRow {
  std::string part;
  Metrics worst;
  Tolerances limit;
  bool passed;
};
std::vector<CheckRow>& check_rows() {
  static std::vector<CheckRow> rows;
  return rows;
}

class CheckTable : public ::testing::Environment {
 public:
  void TearDown() override {
    if (check_rows().empty()) return;
    std::printf("\nop check table: worst over the seeds (limit); derivatives in double, then float against double\n");
    std::printf("%-36s %-20s %-20s %-20s %-20s %-20s %s\n", "part", "dot-product", "FD vs JVP", "FD vs VJP", "accumulate",
                "float vs double", "");
    for (const CheckRow& r : check_rows()) {
      auto cell = [](double v, double lim) { return fmt::format("{:.1e} ({:.0e})", v, lim); };
      std::printf("%-36s %-20s %-20s %-20s %-20s %-20s %s\n", r.part.c_str(), cell(r.worst.dot, r.limit.dot).c_str(),
                  cell(r.worst.fd, r.limit.fd).c_str(), cell(r.worst.fd_vjp, r.limit.fd).c_str(),
                  cell(r.worst.accumulate, r.limit.accumulate).c_str(), cell(r.worst.single, r.limit.single).c_str(),
                  r.passed ? "ok" : "FAILED");
    }
  }
};
const ::testing::Environment* const kCheckTable = ::testing::AddGlobalTestEnvironment(new CheckTable);

// Runs `make(rng, seed)` for `seeds` seeds, checks each case, prints the worst errors.
template <class Make>
Metrics run_cases(const std::string& name, int seeds, Make make, const Tolerances& tol = {}) {
  Metrics worst;
  for (int s = 0; s < seeds; ++s) {
    Rng rng(1000 + 17 * s);
    const auto c = make(rng, s);
    const Metrics m = check_case(c, rng);
    EXPECT_LE(m.dot, tol.dot) << name << " seed " << s;
    EXPECT_LE(m.fd, tol.fd) << name << " seed " << s;
    EXPECT_LE(m.fd_vjp, tol.fd) << name << " seed " << s;
    EXPECT_LE(m.value, tol.value) << name << " seed " << s;
    EXPECT_LE(m.accumulate, tol.accumulate) << name << " seed " << s;
    EXPECT_LE(m.single, tol.single) << name << " seed " << s << ": the float forward";
    worst.dot = std::max(worst.dot, m.dot);
    worst.fd = std::max(worst.fd, m.fd);
    worst.fd_vjp = std::max(worst.fd_vjp, m.fd_vjp);
    worst.value = std::max(worst.value, m.value);
    worst.accumulate = std::max(worst.accumulate, m.accumulate);
    worst.single = std::max(worst.single, m.single);
  }
  std::printf("%-34s %d seeds: dot-product %.2e  FD vs JVP %.2e  FD vs VJP %.2e  (Dual value %.1e, accumulate %.1e)\n",
              name.c_str(), seeds, worst.dot, worst.fd, worst.fd_vjp, worst.value, worst.accumulate);
  check_rows().push_back({name, worst, tol,
                          worst.dot <= tol.dot && worst.fd <= tol.fd && worst.fd_vjp <= tol.fd &&
                              worst.value <= tol.value && worst.accumulate <= tol.accumulate && worst.single <= tol.single});
  ::testing::Test::RecordProperty(name + "_dot", std::to_string(worst.dot));
  ::testing::Test::RecordProperty(name + "_fd", std::to_string(worst.fd));
  return worst;
}

constexpr int kSeeds = 6;

// ------------------------------------------------------------------------------------------
// Cases

struct LameCase {
  std::vector<double> x, scale;  // E, nu
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    R lambda, mu;
    ops::lame_from_young(x[0], x[1], lambda, mu);
    return {lambda, mu};
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    ops::adj_lame_from_young(x[0], x[1], yb[0], yb[1], acc[0], acc[1]);
    return acc;
  }
};

struct DeformationGradientCase {
  double h;
  std::vector<double> x, scale;  // u_c (24)
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    Vec3<R> u[8];
    for (int c = 0; c < 8; ++c) u[c] = get3(x, 3 * c);
    std::vector<R> y;
    put33(y, ops::cell_deformation_gradient(u, R(h)));
    return y;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    Vec3<double> ub[8];
    for (int c = 0; c < 8; ++c) ub[c] = get3(acc, 3 * c);
    ops::adj_cell_deformation_gradient(get33(yb, 0), h, ub);
    for (int c = 0; c < 8; ++c) store_vec(acc, 3 * c, ub[c]);
    return acc;
  }
};

// y = R K(lambda, mu) R^T p; inputs R (9, a general matrix for the adjoint), lambda, mu, p (24).
struct CorotatedApplyCase {
  double h;
  std::vector<double> w;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    const Mat3<R> Rm = get33(x, 0);
    Vec3<R> p[8], y[8];
    R wr[8];
    for (int c = 0; c < 8; ++c) p[c] = get3(x, 11 + 3 * c), wr[c] = R(w[c]);
    ops::corotated_apply(Rm, wr, x[9], x[10], R(h), p, y);
    std::vector<R> out;
    for (int c = 0; c < 8; ++c) put3(out, y[c]);
    return out;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    Vec3<double> p[8], ybar[8], pb[8];
    for (int c = 0; c < 8; ++c) p[c] = get3(x, 11 + 3 * c), ybar[c] = get3(yb, 3 * c), pb[c] = get3(acc, 11 + 3 * c);
    Mat3<double> Rb = mat_at(acc, 0);
    ops::adj_corotated_apply(mat_at(x, 0), w.data(), x[9], x[10], h, p, ybar, Rb, acc[9], acc[10], pb);
    store_mat(acc, 0, Rb);
    for (int c = 0; c < 8; ++c) store_vec(acc, 11 + 3 * c, pb[c]);
    return acc;
  }
};

// f = -R K (R^T x - x); inputs R (9), lambda, mu.
struct OffsetForceCase {
  double h;
  std::vector<double> w;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    Vec3<R> f[8];
    R wr[8];
    for (int c = 0; c < 8; ++c) wr[c] = R(w[c]);
    ops::corotation_offset_force(get33(x, 0), wr, x[9], x[10], R(h), f);
    std::vector<R> out;
    for (int c = 0; c < 8; ++c) put3(out, f[c]);
    return out;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    Vec3<double> fb[8];
    for (int c = 0; c < 8; ++c) fb[c] = get3(yb, 3 * c);
    Mat3<double> Rb = mat_at(acc, 0);
    ops::adj_corotation_offset_force(mat_at(x, 0), w.data(), x[9], x[10], h, fb, Rb, acc[9], acc[10]);
    store_mat(acc, 0, Rb);
    return acc;
  }
};

// R = polar(F); input F (9).
struct PolarCase {
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    Mat3<R> Rm;
    const int status = ops::polar_rotation(get33(x, 0), Rm);
    EXPECT_EQ(status, ops::kPolarOk);
    std::vector<R> y;
    put33(y, Rm);
    return y;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    const Mat3<double> F = mat_at(x, 0);
    Mat3<double> Rm;
    const int status = ops::polar_rotation(F, Rm);
    Mat3<double> Fb = mat_at(acc, 0);
    ops::adj_polar_rotation(F, Rm, status, get33(yb, 0), Fb);
    store_mat(acc, 0, Fb);
    return acc;
  }
};

// The interpreter's Corotation op: R = polar(F(u)); input u (24).
struct CorotationChainCase {
  double h;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    Vec3<R> u[8];
    for (int c = 0; c < 8; ++c) u[c] = get3(x, 3 * c);
    Mat3<R> Rm;
    EXPECT_EQ(ops::polar_rotation(ops::cell_deformation_gradient(u, R(h)), Rm), ops::kPolarOk);
    std::vector<R> y;
    put33(y, Rm);
    return y;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    Vec3<double> u[8], ub[8];
    for (int c = 0; c < 8; ++c) u[c] = get3(x, 3 * c), ub[c] = get3(acc, 3 * c);
    const Mat3<double> F = ops::cell_deformation_gradient(u, h);
    Mat3<double> Rm, Fb = zero33<double>();
    const int status = ops::polar_rotation(F, Rm);
    ops::adj_polar_rotation(F, Rm, status, get33(yb, 0), Fb);
    ops::adj_cell_deformation_gradient(Fb, h, ub);
    for (int c = 0; c < 8; ++c) store_vec(acc, 3 * c, ub[c]);
    return acc;
  }
};

// Contact force of one test point; inputs x (3), v (3), then per plane normal (3) and height.
struct ContactCase {
  int planes = 1;
  double area, dt = 0.01, theta = 0.6;
  std::vector<double> stiffness, alpha;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    ops::GroundPlane<R> g[ops::kMaxGroundPlanes];
    for (int p = 0; p < planes; ++p) g[p] = {get3(x, 6 + 4 * p), x[9 + 4 * p], R(stiffness[p]), R(alpha[p])};
    std::vector<R> y;
    put3(y, ops::contact_force(get3(x, 0), get3(x, 3), R(area), g, planes, R(dt), R(theta)));
    return y;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    ops::GroundPlane<double> g[ops::kMaxGroundPlanes];
    Vec3<double> nb[ops::kMaxGroundPlanes];
    double hb[ops::kMaxGroundPlanes];
    for (int p = 0; p < planes; ++p) {
      g[p] = {get3(x, 6 + 4 * p), x[9 + 4 * p], stiffness[p], alpha[p]};
      nb[p] = get3(acc, 6 + 4 * p);
      hb[p] = acc[9 + 4 * p];
    }
    Vec3<double> xb = get3(acc, 0), vb = get3(acc, 3);
    ops::adj_contact_force(get3(x, 0), get3(x, 3), area, g, planes, dt, theta, get3(yb, 0), xb, vb, nb, hb);
    store_vec(acc, 0, xb);
    store_vec(acc, 3, vb);
    for (int p = 0; p < planes; ++p) store_vec(acc, 6 + 4 * p, nb[p]), acc[9 + 4 * p] = hb[p];
    return acc;
  }
};

// abc = trilinear_inverse(X, p), outputs trilinear_scalar(phi_k, abc) for a list of corner
// value sets phi_k (the coordinate functions phi_c = bit(c, a) give abc itself); input X (24).
struct TrilinearCase {
  Vec3<double> p;
  double tol;
  std::vector<std::vector<double>> phis;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    Vec3<R> X[8];
    for (int c = 0; c < 8; ++c) X[c] = get3(x, 3 * c);
    Vec3<R> abc;
    EXPECT_TRUE(ops::trilinear_inverse(X, to<R>(p), newton_tolerance<R>(tol), abc));
    std::vector<R> y;
    for (const auto& phi : phis) {
      R pr[8];
      for (int c = 0; c < 8; ++c) pr[c] = R(phi[c]);
      y.push_back(ops::trilinear_scalar(pr, abc));
    }
    return y;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    Vec3<double> X[8], Xb[8];
    for (int c = 0; c < 8; ++c) X[c] = get3(x, 3 * c), Xb[c] = get3(acc, 3 * c);
    Vec3<double> abc;
    EXPECT_TRUE(ops::trilinear_inverse(X, p, tol, abc));
    for (size_t k = 0; k < phis.size(); ++k) ops::adj_inverse_then_interpolate(X, abc, phis[k].data(), yb[k], Xb);
    for (int c = 0; c < 8; ++c) store_vec(acc, 3 * c, Xb[c]);
    return acc;
  }
};

// cost(phi) of one point; input phi.
struct SurfaceCostCase {
  double phi_max;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    return {ops::surface_point_cost(x[0], R(phi_max))};
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    acc[0] += yb[0] * ops::surface_point_cost_derivative(x[0], phi_max);
    return acc;
  }
};

// The whole per-point chain of SurfaceConstraintCost::evaluate: X -> abc -> phi -> cost.
struct PointCostCase {
  Vec3<double> p;
  double tol, phi_max;
  std::vector<double> phi;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    Vec3<R> X[8], abc;
    R pr[8];
    for (int c = 0; c < 8; ++c) X[c] = get3(x, 3 * c), pr[c] = R(phi[c]);
    EXPECT_TRUE(ops::trilinear_inverse(X, to<R>(p), newton_tolerance<R>(tol), abc));
    return {ops::surface_point_cost(ops::trilinear_scalar(pr, abc), R(phi_max))};
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    Vec3<double> X[8], Xb[8], abc;
    for (int c = 0; c < 8; ++c) X[c] = get3(x, 3 * c), Xb[c] = get3(acc, 3 * c);
    EXPECT_TRUE(ops::trilinear_inverse(X, p, tol, abc));
    const double value = ops::trilinear_scalar(phi.data(), abc);
    ops::adj_inverse_then_interpolate(X, abc, phi.data(), yb[0] * ops::surface_point_cost_derivative(value, phi_max), Xb);
    for (int c = 0; c < 8; ++c) store_vec(acc, 3 * c, Xb[c]);
    return acc;
  }
};

// ---- case generators ----
LameCase make_lame(Rng& rng, int) {
  LameCase c;
  c.x = {uni(rng, 1e3, 1e5), uni(rng, 0.05, 0.45)};
  c.scale = {c.x[0], 0.05};
  return c;
}

DeformationGradientCase make_deformation_gradient(Rng& rng, int) {
  DeformationGradientCase c;
  c.h = uni(rng, 0.05, 0.2);
  for (int i = 0; i < 24; ++i) c.x.push_back(0.2 * c.h * uni(rng, -1, 1)), c.scale.push_back(0.1 * c.h);
  return c;
}

void push_rotation(std::vector<double>& x, std::vector<double>& scale, const Mat3<double>& R) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) x.push_back(R.m[i][j]), scale.push_back(1.0);
}

CorotatedApplyCase make_corotated_apply(Rng& rng, int seed) {
  CorotatedApplyCase c;
  c.h = uni(rng, 0.05, 0.2);
  c.w = random_weights(rng, c.h, seed % 2 == 1);
  push_rotation(c.x, c.scale, random_rotation(rng));
  const Material m = random_material(rng);
  c.x.push_back(m.lambda), c.scale.push_back(m.lambda);
  c.x.push_back(m.mu), c.scale.push_back(m.mu);
  for (int i = 0; i < 24; ++i) c.x.push_back(0.3 * c.h * uni(rng, -1, 1)), c.scale.push_back(0.3 * c.h);
  return c;
}

OffsetForceCase make_offset_force(Rng& rng, int seed) {
  OffsetForceCase c;
  c.h = uni(rng, 0.05, 0.2);
  c.w = random_weights(rng, c.h, seed % 2 == 1);
  push_rotation(c.x, c.scale, random_rotation(rng));
  const Material m = random_material(rng);
  c.x.push_back(m.lambda), c.scale.push_back(m.lambda);
  c.x.push_back(m.mu), c.scale.push_back(m.mu);
  return c;
}

PolarCase make_polar(Rng& rng, int seed) {
  PolarCase c;
  // small, moderate and large stretches (the large ones need more iterations)
  push_rotation(c.x, c.scale, random_deformation_gradient(rng, seed % 3 == 2 ? 0.45 : (seed % 3 == 1 ? 0.2 : 0.05)));
  return c;
}

CorotationChainCase make_corotation_chain(Rng& rng, int) {
  CorotationChainCase c;
  c.h = uni(rng, 0.05, 0.2);
  // u_c = (Q (I + G) - I) x_c + t + small noise: a rotated, stretched cell
  const Mat3<double> F = random_deformation_gradient(rng, 0.15);
  const Vec3<double> t = make_vec3(uni(rng, -1, 1), uni(rng, -1, 1), uni(rng, -1, 1));
  for (int k = 0; k < 8; ++k) {
    const Vec3<double> xc = ops::corner_offset<double>(k, c.h);
    const Vec3<double> u = F * xc - xc + t;
    for (int a = 0; a < 3; ++a) c.x.push_back(u[a] + 0.02 * c.h * uni(rng, -1, 1)), c.scale.push_back(0.1 * c.h);
  }
  return c;
}

Vec3<double> unit(Vec3<double> v) { return (1.0 / norm(v)) * v; }

// A test point at signed distance `dist` from each plane (planes share the point).
ContactCase make_contact(Rng& rng, int planes, const std::vector<double>& dist) {
  ContactCase c;
  c.planes = planes;
  c.area = uni(rng, 1e-4, 1e-3);
  std::vector<Vec3<double>> n(planes);
  n[0] = unit(make_vec3(uni(rng, -0.3, 0.3), 1.0, uni(rng, -0.3, 0.3)));
  if (planes > 1) n[1] = unit(make_vec3(1.0, uni(rng, -0.3, 0.3), uni(rng, -0.3, 0.3)));
  // x = sum_p a_p n_p + origin with heights chosen so that n_p . x - d_p = dist_p
  const Vec3<double> x = make_vec3(uni(rng, -1, 1), uni(rng, 0, 1), uni(rng, -1, 1));
  const Vec3<double> v = make_vec3(uni(rng, -1, 1), uni(rng, -2, 0.5), uni(rng, -1, 1));
  for (double q : {x.x, x.y, x.z}) c.x.push_back(q), c.scale.push_back(0.01);
  for (double q : {v.x, v.y, v.z}) c.x.push_back(q), c.scale.push_back(1.0);
  for (int p = 0; p < planes; ++p) {
    for (int a = 0; a < 3; ++a) c.x.push_back(n[p][a]), c.scale.push_back(0.1);
    c.x.push_back(dot(n[p], x) - dist[p]), c.scale.push_back(0.01);
    c.stiffness.push_back(uni(rng, 1e5, 1e6));
    c.alpha.push_back(100);
  }
  return c;
}

TrilinearCase make_trilinear(Rng& rng, int) {
  TrilinearCase c;
  const double h = uni(rng, 0.05, 0.2);
  const std::vector<Vec3<double>> X = random_cell(rng, h);
  const Vec3<double> abc = make_vec3(uni(rng, 0.05, 0.95), uni(rng, 0.05, 0.95), uni(rng, 0.05, 0.95));
  c.p = ops::trilinear_point(X.data(), abc);
  c.tol = 1e-13 * h;
  for (const Vec3<double>& q : X)
    for (int a = 0; a < 3; ++a) c.x.push_back(q[a]), c.scale.push_back(h);
  std::vector<double> phi(8);
  for (double& v : phi) v = h * uni(rng, -1.5, 1.5);
  c.phis.push_back(phi);
  for (int a = 0; a < 3; ++a) {
    std::vector<double> coord(8);
    for (int k = 0; k < 8; ++k) coord[k] = corner_bit(k, a);
    c.phis.push_back(coord);
  }
  return c;
}

// ------------------------------------------------------------------------------------------
// OpAdjoint: dot-product and finite-difference tests

// ---- the node-level parts: Newmark right-hand side, system apply, velocity; nodal mass and force

// x = (alpha, beta, mass, u-, v-, (K u-), force); dt and theta fixed (not differentiated).
struct NewmarkRhsCase {
  double dt, theta;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    const auto c = ops::newmark_coefficients(R(dt), R(theta), x[0], x[1]);
    std::vector<R> y;
    put3(y, ops::newmark_rhs(c, x[2], get3(x, 3), get3(x, 6), get3(x, 9), get3(x, 12)));
    return y;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    const auto c = ops::newmark_coefficients(dt, theta, x[0], x[1]);
    Vec3<double> ub = get3(acc, 3), vb = get3(acc, 6), kb = get3(acc, 9), fb = get3(acc, 12);
    ops::NewmarkCoefficientBars<double> cb;
    ops::adj_newmark_rhs(c, x[2], get3(x, 3), get3(x, 6), get3(x, 9), get3(yb, 0), acc[2], ub, vb, kb, fb, cb);
    ops::adj_newmark_coefficients(cb, acc[0], acc[1]);
    store_vec(acc, 3, ub), store_vec(acc, 6, vb), store_vec(acc, 9, kb), store_vec(acc, 12, fb);
    return acc;
  }
};

// x = (alpha, beta, mass, p, (K p)).
struct NewmarkSystemApplyCase {
  double dt, theta;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    const auto c = ops::newmark_coefficients(R(dt), R(theta), x[0], x[1]);
    std::vector<R> y;
    put3(y, ops::newmark_system_apply(c, x[2], get3(x, 3), get3(x, 6)));
    return y;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    const auto c = ops::newmark_coefficients(dt, theta, x[0], x[1]);
    Vec3<double> pb = get3(acc, 3), kb = get3(acc, 6);
    ops::NewmarkCoefficientBars<double> cb;
    ops::adj_newmark_system_apply(c, x[2], get3(x, 3), get3(x, 6), get3(yb, 0), acc[2], pb, kb, cb);
    ops::adj_newmark_coefficients(cb, acc[0], acc[1]);
    store_vec(acc, 3, pb), store_vec(acc, 6, kb);
    return acc;
  }
};

// x = (u, u-, v-).
struct NewmarkVelocityCase {
  double dt, theta;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    const auto c = ops::newmark_coefficients(R(dt), R(theta), R(0), R(0));
    std::vector<R> y;
    put3(y, ops::newmark_velocity(c, get3(x, 0), get3(x, 3), get3(x, 6)));
    return y;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    const auto c = ops::newmark_coefficients(dt, theta, 0.0, 0.0);
    Vec3<double> ub = get3(acc, 0), upb = get3(acc, 3), vpb = get3(acc, 6);
    ops::adj_newmark_velocity(c, get3(yb, 0), ub, upb, vpb);
    store_vec(acc, 0, ub), store_vec(acc, 3, upb), store_vec(acc, 6, vpb);
    return acc;
  }
};

// x = (density); the node's volume is data.
struct NodeMassCase {
  double volume;
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    return {ops::node_mass(x[0], R(volume))};
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    ops::adj_node_mass(volume, yb[0], acc[0]);
    return acc;
  }
};

// x = (mass, gravity, corner sum, point sum).
struct NodeForceCase {
  std::vector<double> x, scale;
  template <class R>
  std::vector<R> forward(const std::vector<R>& x) const {
    std::vector<R> y;
    put3(y, ops::node_force(x[0], get3(x, 1), get3(x, 4), get3(x, 7)));
    return y;
  }
  std::vector<double> vjp(const std::vector<double>& yb, std::vector<double> acc) const {
    Vec3<double> gb = get3(acc, 1), sum_bar = zero3<double>();
    ops::adj_node_force(x[0], get3(x, 1), get3(yb, 0), acc[0], gb, sum_bar);
    store_vec(acc, 1, gb);
    for (int k = 0; k < 3; ++k) acc[4 + k] += sum_bar[k], acc[7 + k] += sum_bar[k];
    return acc;
  }
};

void push_random(std::vector<double>& x, std::vector<double>& scale, Rng& rng, int n, double size) {
  for (int i = 0; i < n; ++i) x.push_back(size * uni(rng, -1, 1)), scale.push_back(size);
}

template <class Case>
Case newmark_case(Rng& rng, int n_vectors) {
  Case c;
  c.dt = uni(rng, 1e-3, 2e-2);
  c.theta = uni(rng, 0.5, 1.0);
  c.x = {uni(rng, 0.01, 1.0), uni(rng, 1e-3, 0.1), uni(rng, 1e-3, 1.0)};
  c.scale = {c.x[0], c.x[1], c.x[2]};
  push_random(c.x, c.scale, rng, 3 * n_vectors, 0.1);
  return c;
}

TEST(OpAdjointNewmark, RightHandSide) {
  run_cases("newmark_rhs", kSeeds, [](Rng& rng, int) { return newmark_case<NewmarkRhsCase>(rng, 4); });
}

TEST(OpAdjointNewmark, SystemApply) {
  run_cases("newmark_system_apply", kSeeds, [](Rng& rng, int) { return newmark_case<NewmarkSystemApplyCase>(rng, 2); });
}

TEST(OpAdjointNewmark, Velocity) {
  run_cases("newmark_velocity", kSeeds, [](Rng& rng, int) {
    NewmarkVelocityCase c;
    c.dt = uni(rng, 1e-3, 2e-2);
    c.theta = uni(rng, 0.5, 1.0);
    push_random(c.x, c.scale, rng, 9, 0.1);
    return c;
  });
}

TEST(OpAdjointNodal, Mass) {
  run_cases("node_mass", kSeeds, [](Rng& rng, int) {
    NodeMassCase c;
    c.volume = uni(rng, 1e-6, 1e-3);
    c.x = {uni(rng, 10, 1000)};
    c.scale = {c.x[0]};
    return c;
  });
}

TEST(OpAdjointNodal, Force) {
  run_cases("node_force", kSeeds, [](Rng& rng, int) {
    NodeForceCase c;
    c.x = {uni(rng, 1e-3, 1.0)};
    c.scale = {c.x[0]};
    push_random(c.x, c.scale, rng, 3, 10.0);
    push_random(c.x, c.scale, rng, 6, 1.0);
    return c;
  });
}

TEST(OpAdjointElasticity, LameFromYoung) { run_cases("lame_from_young", kSeeds, make_lame); }

TEST(OpAdjointElasticity, CellDeformationGradient) {
  run_cases("cell_deformation_gradient", kSeeds, make_deformation_gradient);
}

TEST(OpAdjointElasticity, CorotatedApply) { run_cases("corotated_apply", kSeeds, make_corotated_apply); }

TEST(OpAdjointElasticity, CorotationOffsetForce) {
  run_cases("corotation_offset_force", kSeeds, make_offset_force);
}

TEST(OpAdjointPolar, PolarRotation) {
  // Dual differentiates the converged Higham iterations; they converge to 1e-14, and the
  // tangent of the iteration converges with them (measured ~1e-15).
  Tolerances t;
  t.dot = 1e-12;
  run_cases("polar_rotation", kSeeds, make_polar, t);
}

TEST(OpAdjointPolar, CorotationChainDeformationGradientThenPolar) {
  Tolerances t;
  t.dot = 1e-12;
  run_cases("corotation (F(u) then polar)", kSeeds, make_corotation_chain, t);
}

TEST(OpAdjointPolar, DegenerateCellIsConstantIdentity) {
  // det F < kPolarMinDet (inverted or flattened cell): R = I, a constant, so both the
  // Dual forward and the adjoint give zero.
  Rng rng(77);
  for (double flatten : {0.0, -0.3}) {
    Mat3<double> F = random_deformation_gradient(rng, 0.1);
    for (int i = 0; i < 3; ++i) F.m[i][2] *= flatten;  // squash (0) or invert (< 0) the third column
    Mat3<D> FD, RD;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) FD.m[i][j] = D(F.m[i][j], uni(rng, -1, 1));
    EXPECT_EQ(ops::polar_rotation(FD, RD), ops::kPolarDegenerate);
    Mat3<double> R, Rb, Fb = zero33<double>();
    const int status = ops::polar_rotation(F, R);
    EXPECT_EQ(status, ops::kPolarDegenerate);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        EXPECT_EQ(RD.m[i][j].v, i == j ? 1.0 : 0.0);
        EXPECT_EQ(RD.m[i][j].d, 0.0);
        Rb.m[i][j] = uni(rng, -1, 1);
      }
    ops::adj_polar_rotation(F, R, status, Rb, Fb);
    EXPECT_EQ(frobenius_dot(Fb, Fb), 0.0);
  }
}

TEST(OpAdjointContact, OnePlaneInContact) {
  run_cases("contact_force 1 plane in contact", kSeeds,
            [](Rng& rng, int) { return make_contact(rng, 1, {uni(rng, -0.02, 0.005)}); });
}

TEST(OpAdjointContact, OnePlaneOutOfContact) {
  // alpha dist = 5..15: the soft-min force is small but smooth; both branches of softmin
  run_cases("contact_force 1 plane out of contact", kSeeds,
            [](Rng& rng, int) { return make_contact(rng, 1, {uni(rng, 0.05, 0.15)}); });
}

TEST(OpAdjointContact, TwoPlanesInContact) {
  run_cases("contact_force 2 planes in contact", kSeeds, [](Rng& rng, int) {
    return make_contact(rng, 2, {uni(rng, -0.02, 0.0), uni(rng, -0.02, 0.0)});
  });
}

TEST(OpAdjointContact, TwoPlanesOneInOneOutOfContact) {
  run_cases("contact_force 2 planes, 1 in, 1 out", kSeeds, [](Rng& rng, int) {
    return make_contact(rng, 2, {uni(rng, -0.02, 0.0), uni(rng, 0.05, 0.1)});
  });
}

TEST(OpAdjointTrilinear, InverseThenInterpolate) {
  Tolerances t;
  t.dot = 1e-10;  // Dual differentiates the converged Newton iterations
  run_cases("trilinear inverse + interpolate", kSeeds, make_trilinear, t);
}

TEST(OpAdjointTrilinear, SurfacePointCost) {
  run_cases("surface_point_cost", kSeeds, [](Rng& rng, int) {
    SurfaceCostCase c;
    c.phi_max = uni(rng, 0.02, 0.2);
    c.x = {c.phi_max * uni(rng, -2.5, 2.5)};
    c.scale = {0.1 * c.phi_max};
    return c;
  });
}

TEST(OpAdjointTrilinear, PointCostChain) {
  Tolerances t;
  t.dot = 1e-10;
  // The float inverse stops at 1e-6 h (newton_tolerance) and the cost's slope amplifies that:
  // about 4 digits (ssc evaluates the cost in double only, on the host).
  t.single = 1e-4;
  run_cases("point cost (inverse, phi, cost)", kSeeds, [](Rng& rng, int) {
    const TrilinearCase tc = make_trilinear(rng, 0);
    PointCostCase c;
    c.p = tc.p;
    c.tol = tc.tol;
    c.x = tc.x;
    c.scale = tc.scale;
    c.phi = tc.phis[0];
    // |phi| / phi_max in [0.3, 1.5]: the cost is neither saturated (its derivative would be
    // exponentially small, FD all round-off) nor ~phi^2/2 at tiny phi (1 - exp(-x) cancels).
    Vec3<double> X[8], abc;
    for (int k = 0; k < 8; ++k) X[k] = get3(c.x, 3 * k);
    EXPECT_TRUE(ops::trilinear_inverse(X, c.p, c.tol, abc));
    c.phi_max = std::abs(ops::trilinear_scalar(c.phi.data(), abc)) / uni(rng, 0.3, 1.5);
    return c;
  }, t);
}

// ------------------------------------------------------------------------------------------
// Implicit ops: no gradient with respect to the initial guess; implicit adjoint vs the
// differentiated iterations.

// A copy of ops::trilinear_inverse that starts from `start` instead of the cell centre
// and, once converged, takes `extra` more Newton steps.
template <class R>
bool trilinear_inverse_from(const Vec3<R>* X, Vec3<R> p, R tol, Vec3<R> start, Vec3<R>& abc, int extra = 0) {
  abc = start;
  int converged_at = -1;
  for (int it = 0; it < 40; ++it) {
    const Vec3<R> r = ops::trilinear_point(X, abc) - p;
    if (converged_at < 0 && dot(r, r) <= tol * tol) converged_at = it;
    if (converged_at >= 0 && it - converged_at >= extra) return true;
    abc = abc - inverse(ops::trilinear_jacobian(X, abc)) * r;
  }
  return false;
}

// Implicit Jacobian of abc(X): d abc = -J^-1 sum_c N_c dX_c.
Vec3<double> implicit_abc_jvp(const Vec3<double>* X, Vec3<double> abc, const Vec3<double>* Xd) {
  double N[8];
  ops::trilinear_weights(abc, N);
  Vec3<double> s = zero3<double>();
  for (int c = 0; c < 8; ++c) s += N[c] * Xd[c];
  return -(inverse(ops::trilinear_jacobian(X, abc)) * s);
}

TEST(ImplicitTrilinear, InitialGuessHasNoGradient) {
  double worst_abc = 0, worst_start_grad = 0, worst_adjoint = 0;
  for (int s = 0; s < 8; ++s) {
    Rng rng(500 + s);
    const double h = uni(rng, 0.05, 0.2);
    const std::vector<Vec3<double>> X = random_cell(rng, h);
    const Vec3<double> abc_true = make_vec3(uni(rng, 0.05, 0.95), uni(rng, 0.05, 0.95), uni(rng, 0.05, 0.95));
    const Vec3<double> p = ops::trilinear_point(X.data(), abc_true);
    const double tol = 1e-13 * h;
    Vec3<double> abc0, abc1;
    ASSERT_TRUE(ops::trilinear_inverse(X.data(), p, tol, abc0));  // engine: from the centre
    const Vec3<double> start = make_vec3(uni(rng, 0, 1), uni(rng, 0, 1), uni(rng, 0, 1));
    ASSERT_TRUE(trilinear_inverse_from(X.data(), p, tol, start, abc1));
    worst_abc = std::max(worst_abc, norm(abc1 - abc0));
    // Derivative with respect to the start only (X, p constant): zero at convergence.
    Vec3<D> XD[8];
    for (int c = 0; c < 8; ++c) XD[c] = to<D>(X[c]);
    Vec3<D> startD, abcD;
    for (int a = 0; a < 3; ++a) startD[a] = D(start[a], uni(rng, -1, 1));
    ASSERT_TRUE(trilinear_inverse_from(XD, to<D>(p), D(tol), startD, abcD));
    for (int a = 0; a < 3; ++a) worst_start_grad = std::max(worst_start_grad, std::abs(abcD[a].d));
    // The adjoint depends on the start only through abc: the same to round-off.
    std::vector<double> phi(8);
    for (double& v : phi) v = h * uni(rng, -1, 1);
    Vec3<double> b0[8], b1[8];
    for (int c = 0; c < 8; ++c) b0[c] = b1[c] = zero3<double>();
    ops::adj_inverse_then_interpolate(X.data(), abc0, phi.data(), 1.0, b0);
    ops::adj_inverse_then_interpolate(X.data(), abc1, phi.data(), 1.0, b1);
    double num = 0, den = 0;
    for (int c = 0; c < 8; ++c) num += dot(b1[c] - b0[c], b1[c] - b0[c]), den += dot(b0[c], b0[c]);
    worst_adjoint = std::max(worst_adjoint, std::sqrt(num / den));
  }
  std::printf("trilinear inverse, start anywhere in [0,1]^3 vs the centre: |abc diff| %.2e, |d abc/d start| %.2e, "
              "adjoint rel diff %.2e\n",
              worst_abc, worst_start_grad, worst_adjoint);
  EXPECT_LE(worst_abc, 1e-13);
  EXPECT_LE(worst_start_grad, 1e-12);
  EXPECT_LE(worst_adjoint, 1e-12);
}

TEST(ImplicitTrilinear, ImplicitAdjointMatchesDifferentiatedIterations) {
  // Full gradient of value = phi(abc(X)) with respect to the 24 corner coordinates: the
  // implicit adjoint vs the Dual-instantiated Newton iteration (24 unit seeds). The
  // derivative of a Newton iterate lags the value: stopped at residual r_k, its error is
  // O(|r_(k-1)|), so it depends on where the iteration stops. Three stops: the engine's
  // ops::trilinear_inverse with SurfaceConstraintCost's tolerance 1e-10 h, the same with
  // 1e-13 h, and a converged copy that takes two more Newton steps after reaching 1e-13 h.
  struct Mode {
    const char* name;
    double tol_rel;
    int extra;  // < 0: ops::trilinear_inverse itself
    double bound;
  };
  for (const Mode& mode : {Mode{"ops::trilinear_inverse, tol 1e-10 h", 1e-10, -1, 1e-7},
                           Mode{"ops::trilinear_inverse, tol 1e-13 h", 1e-13, -1, 1e-9},
                           Mode{"converged + 2 Newton steps", 1e-13, 2, 1e-12}}) {
    double worst = 0, worst_abc = 0;
    for (int s = 0; s < 8; ++s) {
      Rng rng(700 + s);
      const double h = uni(rng, 0.05, 0.2);
      const std::vector<Vec3<double>> X = random_cell(rng, h);
      const Vec3<double> p =
          ops::trilinear_point(X.data(), make_vec3(uni(rng, 0.05, 0.95), uni(rng, 0.05, 0.95), uni(rng, 0.05, 0.95)));
      std::vector<double> phi(8);
      for (double& v : phi) v = h * uni(rng, -1, 1);
      Vec3<double> abc;
      ASSERT_TRUE(ops::trilinear_inverse(X.data(), p, mode.tol_rel * h, abc));
      Vec3<double> Xb[8];
      for (int c = 0; c < 8; ++c) Xb[c] = zero3<double>();
      ops::adj_inverse_then_interpolate(X.data(), abc, phi.data(), 1.0, Xb);
      std::vector<double> g_adj, g_fwd, abc_diff, abc_imp;
      D phiD[8];
      for (int c = 0; c < 8; ++c) phiD[c] = D(phi[c]);
      for (int k = 0; k < 24; ++k) {
        Vec3<D> XD[8], abcD;
        Vec3<double> Xd[8];
        for (int c = 0; c < 8; ++c) {
          XD[c] = to<D>(X[c]);
          Xd[c] = zero3<double>();
        }
        XD[k / 3][k % 3].d = 1.0;
        Xd[k / 3][k % 3] = 1.0;
        if (mode.extra < 0)
          ASSERT_TRUE(ops::trilinear_inverse(XD, to<D>(p), D(mode.tol_rel * h), abcD));
        else
          ASSERT_TRUE(trilinear_inverse_from(XD, to<D>(p), D(mode.tol_rel * h), to<D>(make_vec3(0.5, 0.5, 0.5)), abcD,
                                             mode.extra));
        g_fwd.push_back(ops::trilinear_scalar(phiD, abcD).d);
        g_adj.push_back(Xb[k / 3][k % 3]);
        const Vec3<double> imp = implicit_abc_jvp(X.data(), abc, Xd);
        for (int a = 0; a < 3; ++a) abc_diff.push_back(abcD[a].d - imp[a]), abc_imp.push_back(imp[a]);
      }
      std::vector<double> diff(24);
      for (int k = 0; k < 24; ++k) diff[k] = g_fwd[k] - g_adj[k];
      worst = std::max(worst, normv(diff) / normv(g_adj));
      worst_abc = std::max(worst_abc, normv(abc_diff) / normv(abc_imp));
    }
    std::printf("trilinear inverse, %-38s implicit vs Dual iterations: d phi/dX rel diff %.2e, d abc/dX rel diff %.2e\n",
                mode.name, worst, worst_abc);
    EXPECT_LE(worst, mode.bound) << mode.name;
    EXPECT_LE(worst_abc, mode.bound) << mode.name;
  }
}

// Cayley map of a rotation vector: an exact rotation, (I - [w/2]x)^-1 (I + [w/2]x).
template <class R>
Mat3<R> skew(Vec3<R> w) {
  Mat3<R> K = zero33<R>();
  K.m[0][1] = -w.z, K.m[0][2] = w.y;
  K.m[1][0] = w.z, K.m[1][2] = -w.x;
  K.m[2][0] = -w.y, K.m[2][1] = w.x;
  return K;
}
template <class R>
Mat3<R> cayley(Vec3<R> w) {
  const Mat3<R> K = R(0.5) * skew(w);
  return inverse(identity3<R>() - K) * (identity3<R>() + K);
}

// A different solver for the same implicit equations as ops::polar_rotation: Newton on
// the rotation manifold for skew(R^T F) = 0, from the start R0, R <- R cayley(w) with
// M w = axial(S - S^T), S = R^T F, M the exact derivative of axial([w]x S + S^T [w]x).
template <class R>
Mat3<R> polar_by_manifold_newton(const Mat3<R>& F, Mat3<R> Rk, int* iterations) {
  *iterations = 0;
  for (int it = 0; it < 50; ++it) {
    const Mat3<R> S = mul_transposed_left(Rk, F);
    const Vec3<R> a = make_vec3(S.m[2][1] - S.m[1][2], S.m[0][2] - S.m[2][0], S.m[1][0] - S.m[0][1]);
    Mat3<R> M;
    for (int i = 0; i < 3; ++i) {
      Vec3<R> e = zero3<R>();
      e[i] = R(1);
      const Mat3<R> E = skew(e) * S + transpose(S) * skew(e);
      M.m[0][i] = E.m[2][1], M.m[1][i] = E.m[0][2], M.m[2][i] = E.m[1][0];
    }
    const Vec3<R> w = inverse(M) * a;
    Rk = Rk * cayley(w);
    if (*iterations > 0) return Rk;  // one more step after convergence (for the derivative)
    if (value_of(dot(w, w)) < 1e-28) *iterations = it + 1;
  }
  if (*iterations > 0) return Rk;
  *iterations = -1;
  return Rk;
}

double frob(const Mat3<double>& A) { return std::sqrt(frobenius_dot(A, A)); }

TEST(ImplicitPolar, InitialGuessHasNoGradient) {
  // ops::polar_rotation (Higham from X = F) and adj_polar_rotation (which takes F and the
  // converged R only) against Newton on the manifold from a start R0 rotated 0.2-0.5 rad
  // away: same R, zero derivative with respect to R0, same adjoint.
  double worst_R = 0, worst_start_grad = 0, worst_adjoint = 0;
  int max_iterations = 0;
  for (int s = 0; s < 9; ++s) {
    Rng rng(900 + s);
    const Mat3<double> F = random_deformation_gradient(rng, s % 3 == 2 ? 0.4 : 0.15);
    Mat3<double> R_engine;
    ASSERT_EQ(ops::polar_rotation(F, R_engine), ops::kPolarOk);
    Vec3<double> w0 = make_vec3(uni(rng, -1, 1), uni(rng, -1, 1), uni(rng, -1, 1));
    w0 = (uni(rng, 0.2, 0.5) / norm(w0)) * w0;
    const Mat3<double> R0 = R_engine * cayley(w0);
    int its = 0;
    const Mat3<double> R_newton = polar_by_manifold_newton(F, R0, &its);
    ASSERT_GT(its, 0);
    max_iterations = std::max(max_iterations, its);
    worst_R = std::max(worst_R, frob(R_newton - R_engine));
    // d R / d R0 along a tangent direction R0 [omega]x (F constant)
    const Vec3<double> omega = make_vec3(uni(rng, -1, 1), uni(rng, -1, 1), uni(rng, -1, 1));
    const Mat3<double> R0dot = R0 * skew(omega);
    Mat3<D> R0D, FD = to<D>(F);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) R0D.m[i][j] = D(R0.m[i][j], R0dot.m[i][j]);
    const Mat3<D> RD = polar_by_manifold_newton(FD, R0D, &its);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) worst_start_grad = std::max(worst_start_grad, std::abs(RD.m[i][j].d));
    Mat3<double> Rb;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Rb.m[i][j] = uni(rng, -1, 1);
    Mat3<double> Fb0 = zero33<double>(), Fb1 = zero33<double>();
    ops::adj_polar_rotation(F, R_engine, ops::kPolarOk, Rb, Fb0);
    ops::adj_polar_rotation(F, R_newton, ops::kPolarOk, Rb, Fb1);
    worst_adjoint = std::max(worst_adjoint, frob(Fb1 - Fb0) / frob(Fb0));
  }
  std::printf("polar rotation: Higham from F vs manifold Newton from R0 (<= %d its): |R diff| %.2e, |dR/dR0| %.2e, "
              "adjoint rel diff %.2e\n",
              max_iterations, worst_R, worst_start_grad, worst_adjoint);
  EXPECT_LE(worst_R, 1e-13);
  EXPECT_LE(worst_start_grad, 1e-12);
  EXPECT_LE(worst_adjoint, 1e-12);
}

TEST(ImplicitPolar, ImplicitAdjointMatchesDifferentiatedIterations) {
  // The 9x9 Jacobian dR/dF: adj_polar_rotation with 9 unit cotangents vs the Dual-
  // instantiated ops::polar_rotation (Higham iterations) with 9 unit seeds, and vs the
  // Dual manifold Newton.
  double worst_higham = 0, worst_newton = 0;
  for (int s = 0; s < 9; ++s) {
    Rng rng(1100 + s);
    const Mat3<double> F = random_deformation_gradient(rng, s % 3 == 2 ? 0.45 : (s % 3 == 1 ? 0.2 : 0.05));
    Mat3<double> R;
    ASSERT_EQ(ops::polar_rotation(F, R), ops::kPolarOk);
    double J_adj[9][9], J_hig[9][9], J_new[9][9];
    for (int k = 0; k < 9; ++k) {
      Mat3<double> Rb = zero33<double>(), Fb = zero33<double>();
      Rb.m[k / 3][k % 3] = 1;
      ops::adj_polar_rotation(F, R, ops::kPolarOk, Rb, Fb);
      for (int l = 0; l < 9; ++l) J_adj[k][l] = Fb.m[l / 3][l % 3];  // dR_k / dF_l
    }
    for (int l = 0; l < 9; ++l) {
      Mat3<D> FD = to<D>(F), RD;
      FD.m[l / 3][l % 3].d = 1;
      ASSERT_EQ(ops::polar_rotation(FD, RD), ops::kPolarOk);
      int its = 0;
      const Mat3<D> RN = polar_by_manifold_newton(FD, to<D>(R), &its);
      for (int k = 0; k < 9; ++k) J_hig[k][l] = RD.m[k / 3][k % 3].d, J_new[k][l] = RN.m[k / 3][k % 3].d;
    }
    double n = 0, dh = 0, dn = 0;
    for (int k = 0; k < 9; ++k)
      for (int l = 0; l < 9; ++l) {
        n += J_adj[k][l] * J_adj[k][l];
        dh += (J_hig[k][l] - J_adj[k][l]) * (J_hig[k][l] - J_adj[k][l]);
        dn += (J_new[k][l] - J_adj[k][l]) * (J_new[k][l] - J_adj[k][l]);
      }
    worst_higham = std::max(worst_higham, std::sqrt(dh / n));
    worst_newton = std::max(worst_newton, std::sqrt(dn / n));
  }
  std::printf("polar rotation dR/dF: implicit adjoint vs Dual Higham iterations %.2e, vs Dual manifold Newton %.2e\n",
              worst_higham, worst_newton);
  EXPECT_LE(worst_higham, 1e-10);
  EXPECT_LE(worst_newton, 1e-10);
}

// ------------------------------------------------------------------------------------------
// Linear-solve adjoint on the dense Newmark matrix of one cell:
//   A(q) = a_m diag(m) + a_k R K(lambda, mu) R^T,  x = A^-1 b,  J = x_bar . x,
//   b_bar = lambda_adj = A^-1 x_bar (A symmetric),  q_bar = -lambda_adj^T (dA/dq) x,
// with the parameter part through adj_corotated_apply, as in the interpreter's NewmarkSolve
// adjoint. Parameters q: b (24), R (9), lambda, mu, masses (8), alpha, beta.
struct NewmarkCell {
  double h, dt = 0.01, theta = 0.6;
  std::vector<double> w;
  enum { kB = 0, kR = 24, kLambda = 33, kMu = 34, kMass = 35, kAlpha = 43, kBeta = 44, kCount = 45 };

  // Column-major entries of A(q) (24 x 24), for double and Dual alike.
  template <class R>
  std::vector<R> entries(const std::vector<R>& q) const {
    const ops::NewmarkCoefficients<R> c = ops::newmark_coefficients(R(dt), R(theta), q[kAlpha], q[kBeta]);
    const Mat3<R> Rm = get33(q, kR);
    R wr[8];
    for (int k = 0; k < 8; ++k) wr[k] = R(w[k]);
    std::vector<R> A(24 * 24);
    for (int j = 0; j < 24; ++j) {
      Vec3<R> p[8], y[8];
      for (int k = 0; k < 8; ++k) p[k] = zero3<R>();
      p[j / 3][j % 3] = R(1);
      ops::corotated_apply(Rm, wr, q[kLambda], q[kMu], R(h), p, y);
      for (int k = 0; k < 8; ++k) {
        const Vec3<R> col = ops::newmark_system_apply(c, q[kMass + k], p[k], y[k]);
        for (int a = 0; a < 3; ++a) A[24 * j + 3 * k + a] = col[a];
      }
    }
    return A;
  }
  Eigen::Matrix<double, 24, 24> matrix(const std::vector<double>& q) const {
    const std::vector<double> e = entries(q);
    return Eigen::Map<const Eigen::Matrix<double, 24, 24>>(e.data());
  }
  Eigen::Matrix<double, 24, 1> rhs(const std::vector<double>& q) const {
    Eigen::Matrix<double, 24, 1> b;
    for (int i = 0; i < 24; ++i) b[i] = q[kB + i];
    return b;
  }
};

TEST(ImplicitLinearSolve, AdjointIdentityOnTheNewmarkMatrixOfOneCell) {
  double worst_dot = 0, worst_fd = 0, worst_sym = 0;
  for (int s = 0; s < 6; ++s) {
    Rng rng(1300 + s);
    NewmarkCell cell;
    cell.h = uni(rng, 0.05, 0.2);
    cell.w = random_weights(rng, cell.h, false);
    const Material mat = random_material(rng);
    const double rho = uni(rng, 50, 1000);
    std::vector<double> q(NewmarkCell::kCount), scale(NewmarkCell::kCount);
    for (int i = 0; i < 24; ++i) q[i] = uni(rng, -1, 1), scale[i] = 1;
    const Mat3<double> R = random_rotation(rng);
    for (int i = 0; i < 9; ++i) q[NewmarkCell::kR + i] = R.m[i / 3][i % 3], scale[NewmarkCell::kR + i] = 1;
    q[NewmarkCell::kLambda] = mat.lambda, scale[NewmarkCell::kLambda] = mat.lambda;
    q[NewmarkCell::kMu] = mat.mu, scale[NewmarkCell::kMu] = mat.mu;
    for (int k = 0; k < 8; ++k) q[NewmarkCell::kMass + k] = rho * cell.w[k], scale[NewmarkCell::kMass + k] = rho * cell.w[k];
    q[NewmarkCell::kAlpha] = uni(rng, 0, 1), scale[NewmarkCell::kAlpha] = 1;
    q[NewmarkCell::kBeta] = uni(rng, 0, 0.05), scale[NewmarkCell::kBeta] = 0.05;

    const Eigen::Matrix<double, 24, 24> A = cell.matrix(q);
    worst_sym = std::max(worst_sym, (A - A.transpose()).norm() / A.norm());
    Eigen::LLT<Eigen::Matrix<double, 24, 24>> llt(A);
    ASSERT_EQ(llt.info(), Eigen::Success) << "the Newmark matrix must be SPD";
    const Eigen::Matrix<double, 24, 1> x = llt.solve(cell.rhs(q));
    Eigen::Matrix<double, 24, 1> xbar;
    for (int i = 0; i < 24; ++i) xbar[i] = uni(rng, -1, 1);

    // Adjoint.
    const Eigen::Matrix<double, 24, 1> lam = llt.solve(xbar);
    std::vector<double> qb(NewmarkCell::kCount, 0.0);
    for (int i = 0; i < 24; ++i) qb[NewmarkCell::kB + i] = lam[i];
    const auto c = ops::newmark_coefficients(cell.dt, cell.theta, q[NewmarkCell::kAlpha], q[NewmarkCell::kBeta]);
    Vec3<double> xc[8], yb[8], pb[8], kx[8];
    for (int k = 0; k < 8; ++k) {
      xc[k] = make_vec3(x[3 * k], x[3 * k + 1], x[3 * k + 2]);
      yb[k] = (-c.a_k) * make_vec3(lam[3 * k], lam[3 * k + 1], lam[3 * k + 2]);
      pb[k] = zero3<double>();
    }
    Mat3<double> Rb = zero33<double>();
    ops::adj_corotated_apply(R, cell.w.data(), mat.lambda, mat.mu, cell.h, xc, yb, Rb, qb[NewmarkCell::kLambda],
                             qb[NewmarkCell::kMu], pb);
    for (int i = 0; i < 9; ++i) qb[NewmarkCell::kR + i] = Rb.m[i / 3][i % 3];
    ops::corotated_apply(R, cell.w.data(), mat.lambda, mat.mu, cell.h, xc, kx);
    for (int k = 0; k < 8; ++k) {
      const Vec3<double> lk = make_vec3(lam[3 * k], lam[3 * k + 1], lam[3 * k + 2]);
      qb[NewmarkCell::kMass + k] = -c.a_m * dot(lk, xc[k]);
      qb[NewmarkCell::kAlpha] -= q[NewmarkCell::kMass + k] * dot(lk, xc[k]);
      qb[NewmarkCell::kBeta] -= dot(lk, kx[k]);
    }

    // Forward mode: A_dot from the Dual assembly, x_dot = A^-1 (b_dot - A_dot x).
    std::vector<double> qd(NewmarkCell::kCount);
    for (int i = 0; i < NewmarkCell::kCount; ++i) qd[i] = uni(rng, -1, 1) * scale[i];
    std::vector<D> qD(NewmarkCell::kCount);
    for (int i = 0; i < NewmarkCell::kCount; ++i) qD[i] = D(q[i], qd[i]);
    const std::vector<D> AD = cell.entries(qD);
    Eigen::Matrix<double, 24, 24> Adot;
    for (int i = 0; i < 24; ++i)
      for (int j = 0; j < 24; ++j) Adot(i, j) = AD[24 * j + i].d;
    Eigen::Matrix<double, 24, 1> bdot;
    for (int i = 0; i < 24; ++i) bdot[i] = qd[NewmarkCell::kB + i];
    const double jvp = xbar.dot(llt.solve(bdot - Adot * x));
    const double vjp = dotv(qd, qb);
    worst_dot = std::max(worst_dot, std::abs(jvp - vjp) / std::max(std::abs(jvp), std::abs(vjp)));

    // Central differences of J along qd.
    const double eps = 1e-6;
    std::vector<double> qp(q), qm(q);
    for (int i = 0; i < NewmarkCell::kCount; ++i) qp[i] += eps * qd[i], qm[i] -= eps * qd[i];
    const double Jp = xbar.dot(cell.matrix(qp).llt().solve(cell.rhs(qp)));
    const double Jm = xbar.dot(cell.matrix(qm).llt().solve(cell.rhs(qm)));
    worst_fd = std::max(worst_fd, std::abs((Jp - Jm) / (2 * eps) - vjp) / std::abs(vjp));
  }
  std::printf("linear-solve adjoint (one-cell Newmark matrix): asymmetry %.2e, dot-product %.2e, FD %.2e\n", worst_sym,
              worst_dot, worst_fd);
  EXPECT_LE(worst_sym, 1e-14);
  EXPECT_LE(worst_dot, 1e-12);
  EXPECT_LE(worst_fd, 1e-6);
}

}  // namespace
}  // namespace ssc
