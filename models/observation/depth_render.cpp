// Ray-cast depth rendering (see depth_render.h). The BVH is built once per mesh by median
// splits; traversal visits the nearer child first and prunes boxes beyond the best hit.
// Triangles are intersected with Moller-Trumbore without back-face culling and with a tiny
// barycentric tolerance, so rays through a shared edge or vertex never slip between two
// triangles. Per-row random engines keep the noise independent of the thread schedule.
#include "models/observation/depth_render.h"

#include <algorithm>
#include <Eigen/Dense>
#include <cmath>
#include <fmt/format.h>
#include <random>

#include "runtime/errors.h"

namespace ssc {

namespace {

constexpr int kLeafSize = 4;
constexpr int kMaxStack = 128;
constexpr double kBaryTolerance = 1e-10;  // closes cracks between triangles sharing an edge
constexpr double kPi = 3.14159265358979323846;

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// Moller-Trumbore, both sides. Returns the ray parameter or +inf for no hit with t > 0.
double intersect_triangle(const std::array<Eigen::Vector3d, 3>& tri, const Eigen::Vector3d& o,
                          const Eigen::Vector3d& d) {
  constexpr double kNoHit = std::numeric_limits<double>::infinity();
  const Eigen::Vector3d e1 = tri[1] - tri[0], e2 = tri[2] - tri[0];
  const Eigen::Vector3d p = d.cross(e2);
  const double det = e1.dot(p);
  if (!(std::fabs(det) > 1e-14 * e1.norm() * e2.norm() * d.norm())) return kNoHit;  // parallel/degenerate
  const double inv = 1.0 / det;
  const Eigen::Vector3d s = o - tri[0];
  const double a = s.dot(p) * inv;
  if (a < -kBaryTolerance || a > 1 + kBaryTolerance) return kNoHit;
  const Eigen::Vector3d q = s.cross(e1);
  const double b = d.dot(q) * inv;
  if (b < -kBaryTolerance || a + b > 1 + kBaryTolerance) return kNoHit;
  const double t = e2.dot(q) * inv;
  return t > 0 ? t : kNoHit;
}

// Slab test; returns the entry parameter or +inf if the box is missed within (0, t_max).
double intersect_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& o,
                     const Eigen::Vector3d& inv_d, double t_max) {
  double t0 = 0, t1 = t_max;
  for (int k = 0; k < 3; ++k) {
    double a = (lo[k] - o[k]) * inv_d[k], b = (hi[k] - o[k]) * inv_d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return t0 <= t1 ? t0 : std::numeric_limits<double>::infinity();
}

double standard_normal(std::mt19937_64& rng) {
  const double u1 = 1.0 - double(rng() >> 11) * 0x1.0p-53;  // (0, 1]
  const double u2 = double(rng() >> 11) * 0x1.0p-53;        // [0, 1)
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

void check_mesh(const std::vector<Eigen::Vector3d>& vertices, const std::vector<std::array<int, 3>>& triangles) {
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (!vertices[i].allFinite())
      throw InputError(fmt::format("render_depth: vertex {} of the mesh is not finite; the simulated "
                                   "state has diverged or the mesh is broken", i));
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (triangles[t][k] < 0 || std::size_t(triangles[t][k]) >= vertices.size())
        throw InputError(fmt::format("render_depth: triangle {} uses vertex {} but the mesh has {} vertices",
                                     t, triangles[t][k], vertices.size()));
}

// Renders row v into `row` (width values).
void render_row(const DepthCamera& cam, const TriangleBvh& bvh, double noise_std_m, std::uint64_t seed, int v,
                double* row) {
  std::mt19937_64 rng(splitmix64(seed ^ splitmix64(std::uint64_t(v) + 1)));
  const Eigen::Matrix3d r = cam.camera_to_world.topLeftCorner<3, 3>();
  const Eigen::Vector3d origin = eye(cam);
  for (int u = 0; u < cam.width; ++u) {
    const double noise = noise_std_m > 0 ? noise_std_m * standard_normal(rng) : 0.0;
    const Eigen::Vector3d d_cam((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
    const double len = d_cam.norm();
    double t = 0;
    row[u] = 0;
    if (!bvh.intersect(origin, r * (d_cam / len), &t)) continue;
    const double z = (t + noise) / len;  // unit ray -> z depth: z component of the unit ray is 1/len
    if (z >= cam.min_depth && z <= cam.max_depth) row[u] = z;
  }
}

}  // namespace

TriangleBvh::TriangleBvh(const std::vector<Eigen::Vector3d>& vertices,
                         const std::vector<std::array<int, 3>>& triangles) {
  check_mesh(vertices, triangles);
  std::vector<Eigen::Vector3d> centroids;
  for (const auto& t : triangles) {
    tris_.push_back({vertices[t[0]], vertices[t[1]], vertices[t[2]]});
    centroids.push_back((vertices[t[0]] + vertices[t[1]] + vertices[t[2]]) / 3.0);
  }
  order_.resize(triangles.size());
  for (std::size_t i = 0; i < order_.size(); ++i) order_[i] = int(i);
  if (!tris_.empty()) build(0, int(tris_.size()), centroids);
}

int TriangleBvh::build(int begin, int end, const std::vector<Eigen::Vector3d>& centroids) {
  const int index = int(nodes_.size());
  nodes_.emplace_back();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo, clo = lo, chi = hi;
  for (int i = begin; i < end; ++i) {
    for (const auto& p : tris_[order_[i]]) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    clo = clo.cwiseMin(centroids[order_[i]]);
    chi = chi.cwiseMax(centroids[order_[i]]);
  }
  nodes_[index].lo = lo;
  nodes_[index].hi = hi;
  int axis = 0;
  const double extent = (chi - clo).maxCoeff(&axis);
  if (end - begin <= kLeafSize || !(extent > 0)) {
    nodes_[index].first = begin;
    nodes_[index].count = end - begin;
    return index;
  }
  const int mid = (begin + end) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](int a, int b) { return centroids[a][axis] < centroids[b][axis]; });
  const int left = build(begin, mid, centroids);
  const int right = build(mid, end, centroids);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

bool TriangleBvh::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double* t_hit) const {
  if (nodes_.empty()) return false;
  Eigen::Vector3d inv_d;
  for (int k = 0; k < 3; ++k) inv_d[k] = 1.0 / (d[k] != 0 ? d[k] : 1e-300);
  double best = std::numeric_limits<double>::infinity();
  int stack[kMaxStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (intersect_box(node.lo, node.hi, o, inv_d, best) == INFINITY) continue;
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i)
        best = std::min(best, intersect_triangle(tris_[order_[i]], o, d));
      continue;
    }
    const double tl = intersect_box(nodes_[node.left].lo, nodes_[node.left].hi, o, inv_d, best);
    const double tr = intersect_box(nodes_[node.right].lo, nodes_[node.right].hi, o, inv_d, best);
    const bool left_first = tl <= tr;  // push the farther child first so the nearer is visited first
    if ((left_first ? tr : tl) < INFINITY) stack[top++] = left_first ? node.right : node.left;
    if ((left_first ? tl : tr) < INFINITY) stack[top++] = left_first ? node.left : node.right;
  }
  if (best == INFINITY) return false;
  *t_hit = best;
  return true;
}

DepthImage render_depth(const DepthCamera& cam, const TriangleBvh& bvh, double noise_std_m, std::uint64_t seed) {
  validate_camera(cam, fmt::format("render_depth: camera '{}'", cam.name));
  if (!(noise_std_m >= 0) || !std::isfinite(noise_std_m))
    throw InputError(fmt::format("render_depth: noise standard deviation {} m must be >= 0", noise_std_m));
  DepthImage image;
  image.width = cam.width;
  image.height = cam.height;
  image.depth.assign(std::size_t(cam.width) * cam.height, 0.0);
#pragma omp parallel for schedule(dynamic, 4)
  for (int v = 0; v < cam.height; ++v)
    render_row(cam, bvh, noise_std_m, seed, v, image.depth.data() + std::size_t(v) * cam.width);
  return image;
}

DepthImage render_depth(const DepthCamera& cam, const std::vector<Eigen::Vector3d>& vertices,
                        const std::vector<std::array<int, 3>>& triangles, double noise_std_m,
                        std::uint64_t seed) {
  return render_depth(cam, TriangleBvh(vertices, triangles), noise_std_m, seed);
}

std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  return splitmix64(splitmix64(splitmix64(seed) ^ a) ^ b);
}

}  // namespace ssc
