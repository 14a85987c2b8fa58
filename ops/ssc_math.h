// Small fixed-size vector and matrix types shared by every op body.
//
// Op bodies are compiled twice: by the host compiler for the CPU interpreter and, as
// pasted text, by NVRTC for generated kernels. So this header uses no Eigen, no std
// containers and no exceptions; every function is SSC_HD and templated on Real.
#pragma once

// SSC_UNROLL: unroll the loop that follows whole (a loop over a cell's 8 corners) on the host.
// Not on the GPU: with it the diagnosis timing case's shared batch took 68.7 s on one H200
// (--gpus 1 on a two-GPU machine), against 40.8 s before and 40.7 s after on one-GPU H200
// machines (docs/benchmarks.md, "Several GPUs").
#if defined(__CUDACC__) || defined(__CUDACC_RTC__)
#define SSC_HD __host__ __device__
#define SSC_UNROLL
#else
#define SSC_HD
#define SSC_UNROLL _Pragma("GCC unroll 8")
#endif

#ifndef __CUDACC_RTC__
#include <cmath>
#endif

namespace ssc {

template <class Real>
struct Vec3 {
  Real x, y, z;
  SSC_HD Real& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  SSC_HD Real operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

template <class Real> SSC_HD inline Vec3<Real> make_vec3(Real x, Real y, Real z) { return {x, y, z}; }
template <class Real> SSC_HD inline Vec3<Real> zero3() { return {Real(0), Real(0), Real(0)}; }
template <class Real> SSC_HD inline Vec3<Real> operator+(Vec3<Real> a, Vec3<Real> b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
template <class Real> SSC_HD inline Vec3<Real> operator-(Vec3<Real> a, Vec3<Real> b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
template <class Real> SSC_HD inline Vec3<Real> operator-(Vec3<Real> a) { return {-a.x, -a.y, -a.z}; }
template <class Real> SSC_HD inline Vec3<Real> operator*(Real s, Vec3<Real> a) { return {s * a.x, s * a.y, s * a.z}; }
template <class Real> SSC_HD inline Vec3<Real> operator*(Vec3<Real> a, Real s) { return {s * a.x, s * a.y, s * a.z}; }
template <class Real> SSC_HD inline Vec3<Real>& operator+=(Vec3<Real>& a, Vec3<Real> b) { a.x += b.x; a.y += b.y; a.z += b.z; return a; }
template <class Real> SSC_HD inline Vec3<Real>& operator-=(Vec3<Real>& a, Vec3<Real> b) { a.x -= b.x; a.y -= b.y; a.z -= b.z; return a; }
template <class Real> SSC_HD inline Real dot(Vec3<Real> a, Vec3<Real> b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class Real> SSC_HD inline Vec3<Real> cross(Vec3<Real> a, Vec3<Real> b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class Real> SSC_HD inline Real norm(Vec3<Real> a) { return sqrt(dot(a, a)); }

// Row-major 3x3 matrix: m[r][c].
template <class Real>
struct Mat3 {
  Real m[3][3];
};

template <class Real> SSC_HD inline Mat3<Real> identity3() {
  Mat3<Real> r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = i == j ? Real(1) : Real(0);
  return r;
}
template <class Real> SSC_HD inline Mat3<Real> zero33() {
  Mat3<Real> r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = Real(0);
  return r;
}
template <class Real> SSC_HD inline Mat3<Real> transpose(const Mat3<Real>& a) {
  Mat3<Real> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[j][i];
  return r;
}
template <class Real> SSC_HD inline Mat3<Real> operator+(const Mat3<Real>& a, const Mat3<Real>& b) {
  Mat3<Real> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] + b.m[i][j];
  return r;
}
template <class Real> SSC_HD inline Mat3<Real> operator-(const Mat3<Real>& a, const Mat3<Real>& b) {
  Mat3<Real> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] - b.m[i][j];
  return r;
}
template <class Real> SSC_HD inline Mat3<Real> operator*(Real s, const Mat3<Real>& a) {
  Mat3<Real> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = s * a.m[i][j];
  return r;
}
template <class Real> SSC_HD inline Mat3<Real> operator*(const Mat3<Real>& a, const Mat3<Real>& b) {
  Mat3<Real> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      Real s = Real(0);
      for (int k = 0; k < 3; ++k) s += a.m[i][k] * b.m[k][j];
      r.m[i][j] = s;
    }
  return r;
}
template <class Real> SSC_HD inline Vec3<Real> operator*(const Mat3<Real>& a, Vec3<Real> v) {
  return {a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z,
          a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
          a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z};
}
// a^T v without forming the transpose.
template <class Real> SSC_HD inline Vec3<Real> mul_transposed(const Mat3<Real>& a, Vec3<Real> v) {
  return {a.m[0][0] * v.x + a.m[1][0] * v.y + a.m[2][0] * v.z,
          a.m[0][1] * v.x + a.m[1][1] * v.y + a.m[2][1] * v.z,
          a.m[0][2] * v.x + a.m[1][2] * v.y + a.m[2][2] * v.z};
}
// a^T b without forming the transpose.
template <class Real> SSC_HD inline Mat3<Real> mul_transposed_left(const Mat3<Real>& a, const Mat3<Real>& b) {
  Mat3<Real> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      Real s = Real(0);
      for (int k = 0; k < 3; ++k) s += a.m[k][i] * b.m[k][j];
      r.m[i][j] = s;
    }
  return r;
}
template <class Real> SSC_HD inline Real trace(const Mat3<Real>& a) { return a.m[0][0] + a.m[1][1] + a.m[2][2]; }
template <class Real> SSC_HD inline Real det(const Mat3<Real>& a) {
  return a.m[0][0] * (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) -
         a.m[0][1] * (a.m[1][0] * a.m[2][2] - a.m[1][2] * a.m[2][0]) +
         a.m[0][2] * (a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0]);
}
// Cofactor matrix: cof(A) = det(A) A^{-T}.
template <class Real> SSC_HD inline Mat3<Real> cofactor(const Mat3<Real>& a) {
  Mat3<Real> c;
  c.m[0][0] = a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1];
  c.m[0][1] = a.m[1][2] * a.m[2][0] - a.m[1][0] * a.m[2][2];
  c.m[0][2] = a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0];
  c.m[1][0] = a.m[0][2] * a.m[2][1] - a.m[0][1] * a.m[2][2];
  c.m[1][1] = a.m[0][0] * a.m[2][2] - a.m[0][2] * a.m[2][0];
  c.m[1][2] = a.m[0][1] * a.m[2][0] - a.m[0][0] * a.m[2][1];
  c.m[2][0] = a.m[0][1] * a.m[1][2] - a.m[0][2] * a.m[1][1];
  c.m[2][1] = a.m[0][2] * a.m[1][0] - a.m[0][0] * a.m[1][2];
  c.m[2][2] = a.m[0][0] * a.m[1][1] - a.m[0][1] * a.m[1][0];
  return c;
}
template <class Real> SSC_HD inline Mat3<Real> inverse(const Mat3<Real>& a) {
  return (Real(1) / det(a)) * transpose(cofactor(a));
}
template <class Real> SSC_HD inline Mat3<Real> outer(Vec3<Real> a, Vec3<Real> b) {
  Mat3<Real> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a[i] * b[j];
  return r;
}
template <class Real> SSC_HD inline Real frobenius_dot(const Mat3<Real>& a, const Mat3<Real>& b) {
  Real s = Real(0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s += a.m[i][j] * b.m[i][j];
  return s;
}

// Load/store helpers for arrays of 3-vectors stored as consecutive Reals.
template <class Real> SSC_HD inline Vec3<Real> load3(const Real* p, int i) { return {p[3 * i], p[3 * i + 1], p[3 * i + 2]}; }
template <class Real> SSC_HD inline void store3(Real* p, int i, Vec3<Real> v) { p[3 * i] = v.x; p[3 * i + 1] = v.y; p[3 * i + 2] = v.z; }
template <class Real> SSC_HD inline void add3(Real* p, int i, Vec3<Real> v) { p[3 * i] += v.x; p[3 * i + 1] += v.y; p[3 * i + 2] += v.z; }

// Corner c of a hexahedral cell, c = bx + 2 by + 4 bz: its offset bits and the sign
// vector s_c = 2 b - 1 used for the cell-average deformation gradient.
SSC_HD inline int corner_bit(int c, int axis) { return (c >> axis) & 1; }

}  // namespace ssc
