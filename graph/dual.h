// Forward-mode dual numbers for the op tests: Dual<double> carries a value v and one
// directional derivative d. Instantiating an op body of ops/ with Real = Dual<double>,
// with the inputs' d set to a direction x_dot, gives the op's Jacobian-vector product
// J x_dot in the outputs' d (exact, no step size): the reference for the dot-product test
// <J x_dot, y_bar> = <x_dot, J^T y_bar> of every adj_ function.
//
// Everything the op bodies need is here: construction from double (non-explicit, so that
// Real(0), Real(1e-14) and mixed expressions work), arithmetic with duals and scalars,
// unary minus, compound assignment, comparisons on the value only (branches and
// convergence tests follow the value), and sqrt, cbrt, exp, log, log1p, abs, fabs.
// The operators and functions are hidden friends: they are found by argument-dependent
// lookup from the unqualified calls in ops/ (sqrt(...), exp(...)), and, not being visible
// to ordinary lookup, they never hide ::sqrt and friends for Real = double or float.
//
// sizeof(Dual<double>) is 16, so ops/polar.h's float test (sizeof(Real) == 4) picks the
// double tolerance.
#pragma once
#include <cmath>
#include <ostream>

namespace ssc {

template <class T>
struct Dual {
  T v, d;

  Dual() : v(T(0)), d(T(0)) {}
  Dual(double value) : v(T(value)), d(T(0)) {}  // NOLINT: implicit on purpose
  Dual(T value, T derivative) : v(value), d(derivative) {}

  // ---- arithmetic (a scalar operand converts to a dual with d = 0) ----
  friend Dual operator+(const Dual& a, const Dual& b) { return {a.v + b.v, a.d + b.d}; }
  friend Dual operator-(const Dual& a, const Dual& b) { return {a.v - b.v, a.d - b.d}; }
  friend Dual operator*(const Dual& a, const Dual& b) { return {a.v * b.v, a.d * b.v + a.v * b.d}; }
  friend Dual operator/(const Dual& a, const Dual& b) {
    const T q = a.v / b.v;
    return {q, (a.d - q * b.d) / b.v};
  }
  friend Dual operator-(const Dual& a) { return {-a.v, -a.d}; }
  friend Dual operator+(const Dual& a) { return a; }

  Dual& operator+=(const Dual& b) { return *this = *this + b; }
  Dual& operator-=(const Dual& b) { return *this = *this - b; }
  Dual& operator*=(const Dual& b) { return *this = *this * b; }
  Dual& operator/=(const Dual& b) { return *this = *this / b; }

  // ---- comparisons: on the value ----
  friend bool operator==(const Dual& a, const Dual& b) { return a.v == b.v; }
  friend bool operator!=(const Dual& a, const Dual& b) { return a.v != b.v; }
  friend bool operator<(const Dual& a, const Dual& b) { return a.v < b.v; }
  friend bool operator<=(const Dual& a, const Dual& b) { return a.v <= b.v; }
  friend bool operator>(const Dual& a, const Dual& b) { return a.v > b.v; }
  friend bool operator>=(const Dual& a, const Dual& b) { return a.v >= b.v; }

  // ---- elementary functions ----
  friend Dual sqrt(const Dual& a) {
    using std::sqrt;
    const T s = sqrt(a.v);
    return {s, a.d / (T(2) * s)};
  }
  friend Dual cbrt(const Dual& a) {
    using std::cbrt;
    const T c = cbrt(a.v);
    return {c, a.d / (T(3) * c * c)};
  }
  friend Dual exp(const Dual& a) {
    using std::exp;
    const T e = exp(a.v);
    return {e, e * a.d};
  }
  friend Dual expm1(const Dual& a) {
    using std::exp;
    using std::expm1;
    return {expm1(a.v), exp(a.v) * a.d};
  }
  friend Dual log(const Dual& a) {
    using std::log;
    return {log(a.v), a.d / a.v};
  }
  friend Dual log1p(const Dual& a) {
    using std::log1p;
    return {log1p(a.v), a.d / (T(1) + a.v)};
  }
  friend Dual abs(const Dual& a) { return a.v < T(0) ? -a : a; }
  friend Dual fabs(const Dual& a) { return a.v < T(0) ? -a : a; }

  friend std::ostream& operator<<(std::ostream& os, const Dual& a) { return os << "(" << a.v << ", d " << a.d << ")"; }
};

// Value and derivative of plain scalars and duals, for generic test code.
inline double value_of(double x) { return x; }
inline double derivative_of(double) { return 0.0; }
template <class T>
T value_of(const Dual<T>& x) {
  return x.v;
}
template <class T>
T derivative_of(const Dual<T>& x) {
  return x.d;
}

}  // namespace ssc
