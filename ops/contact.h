// Soft-min penalty contact with ground planes, treated implicitly as in the paper.
//
// Test points sit on the rest-pose surface inside active cells and move with their cell's
// trilinear interpolation (weights w_c over its 8 corners), each carrying a share A of the
// surface area. For a plane with unit normal n and height d (signed distance n.x - d), the
// penalty force magnitude is
//   f_cur = -k A softmin(dist),  fdot = -k A softmin'(dist) (n.v),
//   f     = theta (f_cur + dt fdot) + (1 - theta) f_cur,
// the first-order Taylor prediction of the next step's force blended with the theta of
// the time integrator. softmin(x) = -log(1 + exp(-alpha x)) / alpha. The force f n is
// split onto the cell's corners with the weights w_c.
#pragma once
#include "ops/gather.h"
#include "ops/part.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

constexpr int kMaxGroundPlanes = 8;

template <class Real>
struct GroundPlane {
  Vec3<Real> normal;  // unit
  Real height;        // plane: normal . x = height
  Real stiffness;     // k, pascal per metre of penetration
  Real alpha;         // soft-min sharpness, 1/metre
};

// softmin(x) = -log(1 + exp(-alpha x)) / alpha, evaluated without overflow.
template <class Real>
SSC_HD inline Real softmin(Real x, Real alpha) {
  const Real y = -alpha * x;
  const Real lp = y > Real(0) ? y + log1p(exp(-y)) : log1p(exp(y));
  return -lp / alpha;
}

// d softmin / dx = 1 / (exp(alpha x) + 1).
template <class Real>
SSC_HD inline Real softmin_derivative(Real x, Real alpha) {
  const Real y = alpha * x;
  if (y > Real(0)) {
    const Real e = exp(-y);
    return e / (Real(1) + e);
  }
  return Real(1) / (exp(y) + Real(1));
}

// Force on one test point (position x, velocity v, area share A) from all planes.
template <class Real>
SSC_HD inline Vec3<Real> contact_force(Vec3<Real> x, Vec3<Real> v, Real area, const GroundPlane<Real>* planes,
                                       int plane_count, Real dt, Real theta) {
  Vec3<Real> f = zero3<Real>();
  for (int p = 0; p < plane_count; ++p) {
    const GroundPlane<Real>& g = planes[p];
    const Real dist = dot(g.normal, x) - g.height;
    const Real f_cur = -g.stiffness * area * softmin(dist, g.alpha);
    const Real f_dot = -g.stiffness * area * softmin_derivative(dist, g.alpha) * dot(g.normal, v);
    f += (f_cur + theta * dt * f_dot) * g.normal;
  }
  return f;
}

// d softmin / d alpha = (x s' - softmin) / alpha and d s' / d alpha = -x s' (1 - s').
template <class Real>
SSC_HD inline void softmin_alpha_derivatives(Real x, Real alpha, Real& ds, Real& ds1) {
  const Real s = softmin(x, alpha), s1 = softmin_derivative(x, alpha);
  ds = (x * s1 - s) / alpha;
  ds1 = -x * s1 * (Real(1) - s1);
}

// Adjoint of contact_force for the cotangent f_bar: accumulates x_bar, v_bar and, per
// plane, normal_bar, height_bar and, where given, stiffness_bar and alpha_bar. With
// F = f_cur + theta dt fdot and force F n:
//   dF/d dist = -k A (s' + theta dt s'' (n.v)),  dF/d(n.v) = -k A theta dt s',
//   s'' = -alpha s' (1 - s'),  dF/dk = F / k.
template <class Real>
SSC_HD inline void adj_contact_force(Vec3<Real> x, Vec3<Real> v, Real area, const GroundPlane<Real>* planes,
                                     int plane_count, Real dt, Real theta, Vec3<Real> f_bar, Vec3<Real>& x_bar,
                                     Vec3<Real>& v_bar, Vec3<Real>* normal_bar, Real* height_bar,
                                     Real* stiffness_bar = nullptr, Real* alpha_bar = nullptr) {
  for (int p = 0; p < plane_count; ++p) {
    const GroundPlane<Real>& g = planes[p];
    const Real dist = dot(g.normal, x) - g.height;
    const Real nv = dot(g.normal, v);
    const Real s = softmin(dist, g.alpha);
    const Real s1 = softmin_derivative(dist, g.alpha);
    const Real s2 = -g.alpha * s1 * (Real(1) - s1);
    const Real kA = g.stiffness * area;
    const Real F = -kA * s - theta * dt * kA * s1 * nv;
    const Real F_bar = dot(f_bar, g.normal);
    const Real dist_bar = F_bar * (-kA * (s1 + theta * dt * s2 * nv));
    const Real nv_bar = F_bar * (-kA * theta * dt * s1);
    x_bar += dist_bar * g.normal;
    v_bar += nv_bar * g.normal;
    normal_bar[p] += F * f_bar + dist_bar * x + nv_bar * v;
    height_bar[p] -= dist_bar;
    if (stiffness_bar) stiffness_bar[p] += F_bar * F / g.stiffness;
    if (alpha_bar) {
      Real ds, ds1;
      softmin_alpha_derivatives(dist, g.alpha, ds, ds1);
      alpha_bar[p] += F_bar * (-kA) * (ds + theta * dt * ds1 * nv);
    }
  }
}

// The planes' tensor holds 6 values per plane: normal (3), height, stiffness, soft-min alpha.
constexpr int kPlaneValues = 6;

template <class Real>
SSC_HD inline int load_ground_planes(const Real* q, int n, GroundPlane<Real>* planes) {
  if (n > kMaxGroundPlanes) n = kMaxGroundPlanes;
  for (int p = 0; p < n; ++p, q += kPlaneValues) {
    planes[p].normal = make_vec3(q[0], q[1], q[2]);
    planes[p].height = q[3];
    planes[p].stiffness = q[4];
    planes[p].alpha = q[5];
  }
  return n;
}

// Contact point i's position (rest + displacement) and velocity: the weighted sum over its
// cell's corners (ops/gather.h).
template <class Real>
SSC_HD inline void contact_point_state(int i, const int* point_nodes, const Real* point_weights, const Real* node_rest,
                                       const Real* u, const Real* v, Vec3<Real>& x, Vec3<Real>& vel) {
  x = zero3<Real>();
  vel = zero3<Real>();
  for (int c = kPointNodes * i; c < kPointNodes * (i + 1); ++c) {
    const Real w = point_weights[c];
    if (w == Real(0)) continue;
    const int n = point_nodes[c];
    x += w * (load3(node_rest, n) + load3(u, n));
    vel += w * load3(v, n);
  }
}

// ---- the contact op: one contact point each ----

template <class Real>
SSC_HD inline void contact_force_point(int i, const PartContext<Real>& cx, const int* point_nodes, const Real* point_weights,
                                       const Real* point_area, const Real* node_rest, const Real* u_prev,
                                       const Real* v_prev, const Real* ground_planes, const Real* dt, const Real* theta,
                                       Real* point_force) {
  GroundPlane<Real> planes[kMaxGroundPlanes];
  const int plane_count = load_ground_planes(ground_planes, cx.n_plane, planes);
  Vec3<Real> x, vel;
  contact_point_state(i, point_nodes, point_weights, node_rest, u_prev, v_prev, x, vel);
  store3(point_force, i, contact_force(x, vel, point_area[i], planes, plane_count, dt[0], theta[0]));
}

// The point's position and velocity cotangents (x_bar, v_bar; gathered to the point's corners by
// the next parts) and its share of the planes' (plane_bar_share, laid out like the planes'
// tensor; summed over the points by a reduction).
template <class Real>
SSC_HD inline void adj_contact_force_point(int i, const PartContext<Real>& cx, const int* point_nodes, const Real* point_weights,
                                           const Real* point_area, const Real* node_rest, const Real* u_prev,
                                           const Real* v_prev, const Real* ground_planes, const Real* dt,
                                           const Real* theta, const Real* point_force_bar, Real* x_bar, Real* v_bar,
                                           Real* plane_bar_share) {
  GroundPlane<Real> planes[kMaxGroundPlanes];
  const int plane_count = load_ground_planes(ground_planes, cx.n_plane, planes);
  Vec3<Real> x, vel, xb = zero3<Real>(), vb = zero3<Real>();
  contact_point_state(i, point_nodes, point_weights, node_rest, u_prev, v_prev, x, vel);
  Vec3<Real> normal_bar[kMaxGroundPlanes];
  Real height_bar[kMaxGroundPlanes], stiffness_bar[kMaxGroundPlanes], alpha_bar[kMaxGroundPlanes];
  for (int k = 0; k < plane_count; ++k) {
    normal_bar[k] = zero3<Real>();
    height_bar[k] = stiffness_bar[k] = alpha_bar[k] = Real(0);
  }
  adj_contact_force(x, vel, point_area[i], planes, plane_count, dt[0], theta[0], load3(point_force_bar, i), xb, vb,
                    normal_bar, height_bar, stiffness_bar, alpha_bar);
  store3(x_bar, i, xb);
  store3(v_bar, i, vb);
  Real* pb = plane_bar_share + kPlaneValues * cx.n_plane * i;
  for (int k = 0; k < plane_count; ++k, pb += kPlaneValues) {
    pb[0] = normal_bar[k].x, pb[1] = normal_bar[k].y, pb[2] = normal_bar[k].z, pb[3] = height_bar[k];
    pb[4] = stiffness_bar[k], pb[5] = alpha_bar[k];
  }
}

#ifdef SSC_OP_SPECS
// Soft-min penalty force at every contact point from u-, v- gathered at its edge's nodes.
inline OpSpec contact_force_spec() {
  OpSpec s;
  s.name = "contact_force";
  s.domain = Domain::Point;
  s.slots = {in("u_prev", Access::Gather), in("v_prev", Access::Gather), in("ground_planes"), constant_in("dt"),
             constant_in("theta"), out("point_force")};
  s.scratch = {{"xbar", Domain::Point, 3, ""}, {"vbar", Domain::Point, 3, ""}, {"planebar", Domain::Point, 0, "ground_planes"}};
  s.forward = {part("contact_force", Extent::Point, SSC_PART(contact_force_point),
                    {"#point_nodes", "#point_weights", "#point_area", "#node_rest^", "u_prev^", "v_prev^", "ground_planes", "dt",
                     "theta", "point_force"})};
  s.adjoint = {part("contact_force", Extent::Point, SSC_ADJOINT_PART(adj_contact_force_point),
                    {"#point_nodes", "#point_weights", "#point_area", "#node_rest^", "u_prev^", "v_prev^", "ground_planes", "dt",
                     "theta", "d_point_force", "$xbar", "$vbar", "$planebar"}),
               part("contact_force_gather", Extent::Node, SSC_ADJOINT_PART(add_point_sum),
                    {"$xbar^", "#point_weights", "#node_point_offset", "#node_point_entry", "d_u_prev"}),
               part("contact_force_gather", Extent::Node, SSC_ADJOINT_PART(add_point_sum),
                    {"$vbar^", "#point_weights", "#node_point_offset", "#node_point_entry", "d_v_prev"}),
               reduction("contact_force_reduce", {"$planebar"}, {"d_ground_planes"})};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
