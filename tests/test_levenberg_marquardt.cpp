// Tests of the Levenberg-Marquardt optimiser (models/optim/levenberg_marquardt.h) on residual
// functions with known minima, and of explicit bounds on the parameter axes
// (with_bounds in models/optim/parameter_space.h) that it and every other optimiser move in.
// Expected values come from closed forms (linear least squares by QR, Rosenbrock's minimum,
// the bounds themselves), never from the code under test. The fits on simulations are in
// tests/test_optim.cpp (ReconstructionLeastSquares.*).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "models/optim/levenberg_marquardt.h"
#include "models/optim/parameter_space.h"
#include "runtime/errors.h"
#include "tests/expect_input_error.h"

namespace ssc {
namespace {

using Vec = Eigen::VectorXd;
using Residuals = std::function<Vec(const Vec&)>;

Vec vec(std::initializer_list<double> v) {
  Vec out(int(v.size()));
  int i = 0;
  for (double x : v) out[i++] = x;
  return out;
}

// Drives the optimiser through ask/tell until it is done; returns the number of rounds and
// calls `seen` with every point asked.
int drive(LevenbergMarquardt& lm, const Residuals& f, const std::function<void(const Vec&)>& seen = {}) {
  int rounds = 0;
  while (!lm.done() && rounds < 10000) {
    std::vector<ResidualVector> values;
    for (const Vec& z : lm.ask()) {
      if (seen) seen(z);
      values.push_back({f(z), {}});
    }
    lm.tell(values);
    ++rounds;
  }
  return rounds;
}

TEST(LevenbergMarquardt, LinearLeastSquaresConvergesInFewIterations) {
  // r = A z - b, 30 residuals, 4 unknowns, columns scaled over 4 decades, not a zero-residual
  // problem. Gauss-Newton solves it in one step; the damping (1e-3 at first) costs a few more.
  Eigen::MatrixXd A(30, 4);
  Vec b(30);
  for (int i = 0; i < 30; ++i) {
    for (int j = 0; j < 4; ++j) A(i, j) = std::sin(0.37 * (i + 1) * (j + 1.7) + j) * std::pow(10.0, j - 2);
    b[i] = std::cos(2.0 * i);
  }
  const Vec solution = A.colPivHouseholderQr().solve(b);
  ASSERT_EQ(A.colPivHouseholderQr().rank(), 4);
  LevenbergMarquardt lm(Vec::Zero(4), OptimizerOptions{}, 1e-4);
  const int rounds = drive(lm, [&](const Vec& z) { return Vec(A * z - b); });
  std::printf("linear: %d iterations, %d rounds (%s), |z - z*| / |z*| = %.2e, damping %.2e\n", lm.iterations(), rounds,
              lm.stop_reason().c_str(), (lm.best_point() - solution).norm() / solution.norm(), lm.damping());
  EXPECT_TRUE(lm.converged()) << lm.stop_reason();
  EXPECT_EQ(lm.stop_reason().rfind("converged: ", 0), 0u);
  EXPECT_LE(lm.iterations(), 6);
  EXPECT_LT((lm.best_point() - solution).norm(), 1e-6 * solution.norm());
  EXPECT_NEAR(lm.best_cost(), 0.5 * (A * solution - b).squaredNorm(), 1e-12);
  // The forward-difference Jacobian of a linear function is A (to rounding).
  EXPECT_LT((lm.jacobian() - A).norm(), 1e-8 * A.norm());
}

TEST(LevenbergMarquardt, RosenbrockResidualsConverge) {
  // (1 - x)^2 + 100 (y - x^2)^2 as r = (1 - x, 10 (y - x^2)): minimum (1, 1), cost 0 there,
  // from the classic start (-1.2, 1) along the curved valley.
  LevenbergMarquardt lm(vec({-1.2, 1}), OptimizerOptions{}, 1e-7);
  int evaluations = 0;
  drive(lm, [&](const Vec& z) {
    ++evaluations;
    return vec({1 - z[0], 10 * (z[1] - z[0] * z[0])});
  });
  std::printf("rosenbrock: %d iterations, %d evaluations (%s), error %.2e\n", lm.iterations(), evaluations,
              lm.stop_reason().c_str(), (lm.best_point() - vec({1, 1})).norm());
  EXPECT_TRUE(lm.converged()) << lm.stop_reason();
  EXPECT_LT((lm.best_point() - vec({1, 1})).norm(), 1e-5);
  EXPECT_LE(lm.iterations(), 40);
}

TEST(LevenbergMarquardt, TrialsOfRejectionsAheadTakeTheSameStepsInFewerRounds) {
  // Rosenbrock from (-1.2, 1) rejects some trials. Driven with the trials of up to two more
  // rejections evaluated in the same round as each trial (lookahead, tell_in_order), the
  // optimiser takes the same accepted steps, bit for bit, in fewer rounds.
  const Residuals f = [](const Vec& z) { return vec({1 - z[0], 10 * (z[1] - z[0] * z[0])}); };
  LevenbergMarquardt plain(vec({-1.2, 1}), OptimizerOptions{}, 1e-7);
  std::vector<Vec> plain_path;
  int plain_rounds = 0, rejected = 0;
  while (!plain.done() && plain_rounds < 10000) {
    std::vector<ResidualVector> values;
    for (const Vec& z : plain.ask()) values.push_back({f(z), {}});
    plain.tell(values);
    ++plain_rounds;
    if (plain.accepted()) plain_path.push_back(plain.best_point());
    else ++rejected;
  }
  LevenbergMarquardt ahead(vec({-1.2, 1}), OptimizerOptions{}, 1e-7);
  std::vector<Vec> ahead_path;
  int ahead_rounds = 0, told_ahead = 0;
  while (!ahead.done() && ahead_rounds < 10000) {
    std::vector<Vec> trials = {ahead.trial()};
    for (const Vec& z : ahead.lookahead(2)) trials.push_back(z);
    std::vector<std::vector<ResidualVector>> groups;
    for (const Vec& trial : trials) {
      groups.emplace_back();
      for (const Vec& z : ahead.points_for(trial)) groups.back().push_back({f(z), {}});
    }
    const int taken = ahead.tell_in_order(groups, std::vector<std::string>(trials.size()), trials);
    ++ahead_rounds;
    told_ahead += taken > 0;
    if (taken >= 0) ahead_path.push_back(ahead.best_point());
  }
  std::printf("rosenbrock: %d rounds (%d rejected trials) one trial a round, %d with two trials ahead (%d accepted "
              "from ahead)\n", plain_rounds, rejected, ahead_rounds, told_ahead);
  ASSERT_GE(rejected, 2);
  EXPECT_EQ(ahead.stop_reason(), plain.stop_reason());
  EXPECT_EQ(ahead.iterations(), plain.iterations());
  ASSERT_EQ(ahead_path.size(), plain_path.size());
  for (size_t k = 0; k < plain_path.size(); ++k) EXPECT_EQ(ahead_path[k], plain_path[k]) << "step " << k;
  EXPECT_EQ(ahead.best_cost(), plain.best_cost());
  EXPECT_GT(told_ahead, 0);
  EXPECT_LT(ahead_rounds, plain_rounds);
}

TEST(LevenbergMarquardt, TheSecantTermLengthensTheStepsOfALargeResidualFit) {
  // The point (A cos z, A sin z) on a circle of radius A = 10, as near as it gets to (0, b), b = 0.5:
  // r = (A cos z, A sin z - b), the minimum at z = pi / 2 with the residual A - b, far from 0.
  // J'J = A^2 everywhere, while the cost's curvature is A b sin z: Gauss-Newton's steps are b / A cos z
  // (one twentieth of the way), and it creeps. The secant term learns the curvature from J's change.
  const double A = 10, b = 0.5;
  const Residuals circle = [&](const Vec& z) { return vec({A * std::cos(z[0]), A * std::sin(z[0]) - b}); };
  OptimizerOptions with_secant, gauss_newton;
  with_secant.max_iterations = gauss_newton.max_iterations = 200;
  gauss_newton.lm_secant = false;
  with_secant.lm_standard_errors = gauss_newton.lm_standard_errors = 0;  // two residuals: no statistics
  LevenbergMarquardt a(vec({0.3}), with_secant, 1e-7), g(vec({0.3}), gauss_newton, 1e-7);
  drive(a, circle);
  drive(g, circle);
  std::printf("circle: with the secant term %d iterations (%s), z = %.9f; Gauss-Newton alone %d (%s), z = %.9f\n",
              a.iterations(), a.stop_reason().c_str(), a.best_point()[0], g.iterations(), g.stop_reason().c_str(),
              g.best_point()[0]);
  EXPECT_TRUE(a.converged()) << a.stop_reason();
  EXPECT_NEAR(a.best_point()[0], M_PI / 2, 1e-4);
  EXPECT_LE(a.iterations(), 15);
  EXPECT_GT(g.iterations(), 3 * a.iterations());
}

TEST(LevenbergMarquardt, IterationLimitAndGradientAtTheStart) {
  OptimizerOptions o;
  o.max_iterations = 2;
  const Residuals rosenbrock = [](const Vec& z) { return vec({1 - z[0], 10 * (z[1] - z[0] * z[0])}); };
  LevenbergMarquardt limited(vec({-1.2, 1}), o, 1e-7);
  drive(limited, rosenbrock);
  EXPECT_EQ(limited.stop_reason(), "iteration limit");
  EXPECT_EQ(limited.iterations(), 2);
  EXPECT_FALSE(limited.converged());
  // At the minimum of a zero-residual problem the gradient is 0 before any step.
  LevenbergMarquardt at_minimum(vec({1, 1}), OptimizerOptions{}, 1e-7);
  drive(at_minimum, rosenbrock);
  EXPECT_EQ(at_minimum.stop_reason(), "converged: gradient");
  EXPECT_EQ(at_minimum.iterations(), 0);
}

TEST(LevenbergMarquardt, AnEntryThatChangesItsMatchHasNoDerivative) {
  // Entry 0 is smooth in both points; entry 1 is matched at the trial and unmatched in the probe
  // (switched to the constant term): its Jacobian entry is 0, not (5 - 0.3) / h.
  LevenbergMarquardt lm(vec({0.0}), OptimizerOptions{}, 1e-3);
  ASSERT_EQ(lm.ask().size(), 2u);
  EXPECT_EQ(lm.ask()[1][0], 1e-3);
  lm.tell({{vec({1.0, 0.3}), {1, 1}}, {vec({1.002, 5.0}), {1, 0}}});
  ASSERT_TRUE(lm.accepted());
  EXPECT_NEAR(lm.jacobian()(0, 0), 2.0, 1e-12);
  EXPECT_EQ(lm.jacobian()(1, 0), 0.0);
  EXPECT_NEAR(lm.gradient_norm(), 2.0, 1e-12);  // J'r = 2 x 1 + 0 x 0.3
}

TEST(LevenbergMarquardt, FailedEvaluations) {
  // At the start: the start fails, with the message. Later: a rejected step, the damping rises
  // and a shorter step is proposed from the same point.
  LevenbergMarquardt first(vec({0.0}), OptimizerOptions{}, 1e-4);
  first.tell({}, "step 3: exploded");
  EXPECT_TRUE(first.done());
  EXPECT_FALSE(first.converged());
  EXPECT_EQ(first.stop_reason(), "failed: simulation");
  EXPECT_EQ(first.failure(), "step 3: exploded");

  const Residuals f = [](const Vec& z) { return vec({z[0] - 0.5, 0.5 * (z[0] - 0.5)}); };
  LevenbergMarquardt later(vec({0.0}), OptimizerOptions{}, 1e-4);
  std::vector<ResidualVector> values;
  for (const Vec& z : later.ask()) values.push_back({f(z), {}});
  later.tell(values);
  const Vec trial = later.ask()[0];
  const double damping = later.damping(), cost = later.best_cost();
  later.tell({}, "step 7: the solve did not converge");
  EXPECT_FALSE(later.done());
  EXPECT_FALSE(later.accepted());
  EXPECT_EQ(later.damping(), 2 * damping);
  EXPECT_EQ(later.best_point()[0], 0.0);
  EXPECT_EQ(later.best_cost(), cost);
  EXPECT_LT(std::abs(later.ask()[0][0]), std::abs(trial[0]));  // shorter
  drive(later, f);
  EXPECT_TRUE(later.converged()) << later.stop_reason();
  EXPECT_NEAR(later.best_point()[0], 0.5, 1e-6);
}

TEST(LevenbergMarquardt, StopsOnceTheStepLeftIsATenthOfAStandardError) {
  // 400 noisy points of a line through the origin, slope z0, and one residual z1^2 whose
  // Gauss-Newton steps only halve z1: the cost falls by ever smaller amounts, each far below
  // what the noise lets the data tell. The statistical tolerance (0.01 / (m - n)) stops it
  // sooner than the 1e-7 alone, with z0 within a tenth of its standard error of the least-squares
  // slope (the closed form sum x y / sum x^2).
  const int m = 400;
  Vec x(m), y(m);
  unsigned state = 12345;
  for (int i = 0; i < m; ++i) {
    state = state * 1103515245u + 12345u;
    x[i] = 0.01 * (i + 1);
    y[i] = 2 * x[i] + (double((state >> 8) % 2001) / 1000 - 1);  // noise in [-1, 1]
  }
  const Residuals f = [&](const Vec& z) {
    Vec r(m + 1);
    r.head(m) = z[0] * x - y;
    r[m] = z[1] * z[1];
    return r;
  };
  const double slope = x.dot(y) / x.squaredNorm();
  const double sigma = std::sqrt((slope * x - y).squaredNorm() / (m - 1));
  const double standard_error = sigma / x.norm();
  OptimizerOptions strict, statistical;
  strict.lm_standard_errors = 0;
  LevenbergMarquardt a(vec({0.0, 1.0}), strict, 1e-7), b(vec({0.0, 1.0}), statistical, 1e-7);
  drive(a, f);
  drive(b, f);
  std::printf("1e-7 alone: %d iterations, z = (%.6f, %.4f); statistical: %d iterations, z = (%.6f, %.4f); "
              "least squares %.6f, standard error %.4f\n",
              a.iterations(), a.best_point()[0], a.best_point()[1], b.iterations(), b.best_point()[0],
              b.best_point()[1], slope, standard_error);
  EXPECT_TRUE(a.converged()) << a.stop_reason();
  EXPECT_TRUE(b.converged()) << b.stop_reason();
  EXPECT_LT(b.iterations(), a.iterations());
  EXPECT_LT(std::abs(b.best_point()[0] - slope), 0.1 * standard_error);
}

TEST(LevenbergMarquardt, AnAxisPushedAgainstItsBoundIsHeldThere) {
  // x = 1.5 sigmoid(z0) (a plausible range [0, 1.5]) wants 2, beyond the bound; y = z1 wants
  // 0.3, coupled to x as E is to a drag coefficient. With the axis marked bounded the fit holds x
  // at the bound once saturated and converges on y; unmarked it creeps towards z0 = infinity.
  const auto sigmoid = [](double z) { return 1 / (1 + std::exp(-z)); };
  const Residuals f = [&](const Vec& z) {
    const double x = 1.5 * sigmoid(z[0]);
    return vec({x - 2, z[1] - 0.3 + 0.2 * (x - 2), 0.1 * (z[1] - 0.3)});
  };
  OptimizerOptions o;
  o.max_iterations = 30;
  LevenbergMarquardt held(vec({0.0, 0.0}), o, 1e-7, {1, 0});
  drive(held, f);
  EXPECT_TRUE(held.converged()) << held.stop_reason();
  EXPECT_EQ(held.held_at_bound(), 1);
  EXPECT_GE(1.5 * sigmoid(held.best_point()[0]), 1.5 * (1 - 1.1e-3));
  EXPECT_LT(held.iterations(), 15);
  LevenbergMarquardt creeping(vec({0.0, 0.0}), o, 1e-7);
  drive(creeping, f);
  EXPECT_GT(creeping.iterations(), held.iterations());
  EXPECT_EQ(creeping.held_at_bound(), 0);

  // Saturated at the start but pulled inward (the minimum at x = 0.75): released, and it gets there.
  const Residuals inward = [&](const Vec& z) { return vec({1.5 * sigmoid(z[0]) - 0.75, z[1] - 0.3}); };
  LevenbergMarquardt released(vec({8.0, 0.0}), o, 1e-7, {1, 0});
  drive(released, inward);
  EXPECT_TRUE(released.converged()) << released.stop_reason();
  EXPECT_NEAR(1.5 * sigmoid(released.best_point()[0]), 0.75, 1e-6);
  EXPECT_EQ(released.held_at_bound(), 0);
}

// ---- explicit bounds on the axes --------------------------------------------------------

ParameterAxis axis(const std::string& name, ParameterAxis::Kind kind) {
  ParameterAxis a;
  a.name = name;
  a.kind = kind;
  return a;
}

TEST(ParameterBounds, AxesBecomeBoundedAndLogarithmicForPositiveParameters) {
  const ParameterAxis e = with_bounds(axis("youngs_modulus", ParameterAxis::Kind::Positive), 1e3, 1e5);
  EXPECT_EQ(e.kind, ParameterAxis::Kind::Bounded);
  EXPECT_TRUE(e.logarithmic);
  ParameterAxis nu = axis("poisson_ratio", ParameterAxis::Kind::Bounded);
  nu.lower = 0.01, nu.upper = 0.49;
  const ParameterAxis nu_bounded = with_bounds(nu, 0.2, 0.6);  // within the axis's own range
  EXPECT_EQ(nu_bounded.lower, 0.2);
  EXPECT_EQ(nu_bounded.upper, 0.49);
  EXPECT_FALSE(nu_bounded.logarithmic);
  const ParameterAxis h = with_bounds(axis("ground.height", ParameterAxis::Kind::Free), -0.5, 0.5);
  EXPECT_FALSE(h.logarithmic);
  const ParameterSpace space({e, nu_bounded, h});
  // Logarithmic: the sigmoid's midpoint is the geometric mean, z = logit(log(x / lo) / log(hi / lo)).
  const Vec z = space.to_internal(vec({1e4, 0.3, 0.25}));
  EXPECT_NEAR(z[0], 0.0, 1e-14);
  EXPECT_NEAR(z[1], std::log(0.1 / 0.19), 1e-14);
  EXPECT_NEAR(z[2], std::log(0.75 / 0.25), 1e-14);
  const Vec x = space.to_physical(vec({std::log(3.0), 0, 0}));  // sigmoid 3/4: lo (hi / lo)^(3/4)
  EXPECT_NEAR(x[0], 1e3 * std::pow(100.0, 0.75), 1e-10 * x[0]);
  // Never beyond the bounds, however far z goes.
  for (double t : {-1e6, -1e3, -40.0, 0.0, 40.0, 1e3, 1e6}) {
    const Vec xt = space.to_physical(Vec::Constant(3, t));
    for (int i = 0; i < 3; ++i) {
      EXPECT_GE(xt[i], space.axes()[size_t(i)].lower) << i << " z = " << t;
      EXPECT_LE(xt[i], space.axes()[size_t(i)].upper) << i << " z = " << t;
    }
  }
  // dx/dz against central differences.
  const Vec z0 = vec({0.7, -0.4, 1.3});
  const Vec g = space.gradient_to_internal(z0, Vec::Ones(3));
  for (int i = 0; i < 3; ++i) {
    Vec zp = z0, zm = z0;
    zp[i] += 1e-6, zm[i] -= 1e-6;
    const double fd = (space.to_physical(zp)[i] - space.to_physical(zm)[i]) / 2e-6;
    EXPECT_NEAR(g[i], fd, 1e-7 * std::abs(fd)) << i;
  }
}

TEST(ParameterBounds, OpenEndsAndBadBounds) {
  // An infinite upper end (or an infinite lower end of a free axis) leaves the axis as it is; a
  // positive axis bounded from 0 (or from -inf) is linear on [0, upper]; bounds that leave no
  // value or are NaN are input errors naming the parameter.
  const ParameterAxis e = axis("youngs_modulus", ParameterAxis::Kind::Positive);
  EXPECT_EQ(with_bounds(e, 10, INFINITY).kind, ParameterAxis::Kind::Positive);
  EXPECT_EQ(with_bounds(axis("gravity.y", ParameterAxis::Kind::Free), -INFINITY, 5).kind, ParameterAxis::Kind::Free);
  for (const double lower : {0.0, -double(INFINITY)}) {
    const ParameterAxis linear = with_bounds(e, lower, 1.5);
    EXPECT_EQ(linear.kind, ParameterAxis::Kind::Bounded);
    EXPECT_FALSE(linear.logarithmic);
    EXPECT_EQ(linear.lower, 0.0);
    EXPECT_EQ(linear.upper, 1.5);
  }
  expect_input_error([&] { with_bounds(e, 1e5, 1e3); }, {"bounds of youngs_modulus", "leave no value"});
  expect_input_error([&] { with_bounds(e, 1, NAN); }, {"bounds of youngs_modulus", "numbers"});
  ParameterAxis nu = axis("poisson_ratio", ParameterAxis::Kind::Bounded);
  nu.lower = 0.01, nu.upper = 0.49;
  expect_input_error([&] { with_bounds(nu, 0.6, 0.7); }, {"bounds of poisson_ratio", "leave no value", "0.01", "0.49"});
}

TEST(ParameterBounds, LevenbergMarquardtStopsOnTheBoundItCannotPass) {
  // r = x - 500 on a logarithmic axis [1, 100] and r = x - 5 on a linear one [0, 2]: the
  // minimum within the bounds is the upper bound; no point asked ever lies beyond it, and the
  // fit ends there with a converged reason, both axes held at their bounds. Started on the
  // lower bound's 2 % margin.
  const ParameterSpace space({with_bounds(axis("youngs_modulus", ParameterAxis::Kind::Positive), 1, 100),
                              with_bounds(axis("ground.height", ParameterAxis::Kind::Free), 0, 2)});
  LevenbergMarquardt lm(space.to_internal(vec({std::pow(100.0, 0.02), 0.04})), OptimizerOptions{}, 1e-4, {1, 1});
  double highest0 = 0, highest1 = 0;
  drive(
      lm, [&](const Vec& z) { const Vec x = space.to_physical(z); return vec({x[0] - 500, x[1] - 5}); },
      [&](const Vec& z) {
        const Vec x = space.to_physical(z);
        highest0 = std::max(highest0, x[0]);
        highest1 = std::max(highest1, x[1]);
      });
  const Vec x = space.to_physical(lm.best_point());
  std::printf("bounded: %d iterations (%s), x = (%.6g, %.6g)\n", lm.iterations(), lm.stop_reason().c_str(), x[0], x[1]);
  EXPECT_TRUE(lm.converged()) << lm.stop_reason();
  EXPECT_LE(highest0, 100.0);
  EXPECT_LE(highest1, 2.0);
  EXPECT_GT(x[0], 99.0);
  EXPECT_GT(x[1], 1.98);
  EXPECT_EQ(lm.held_at_bound(), 2);
  EXPECT_LE(lm.iterations(), 25);  // 39 before an axis was held at its bound (19 by Gauss-Newton alone)
}

}  // namespace
}  // namespace ssc
