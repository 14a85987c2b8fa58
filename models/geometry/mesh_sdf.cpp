#include "models/geometry/mesh_sdf.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "models/geometry/grid_placement.h"
#include "runtime/errors.h"

namespace ssc {

namespace {

using Eigen::Vector3d;

constexpr int kLeafSize = 8;
// Barill et al.'s beta: a cluster is approximated when |q - centre| > beta * radius. 2.5
// keeps the winding number error near 0.025 on the scans (2.0 gives about 0.04).
constexpr double kFarFieldRatio = 2.5;
constexpr double kFourPi = 4.0 * M_PI;
constexpr double kAmbiguousLow = 0.25, kAmbiguousHigh = 0.75;
constexpr double kMaxAmbiguousFraction = 0.01;
constexpr double kAmbiguityMinDistanceCells = 2.0;

struct Triangle {
  Triangle() = default;
  Triangle(const Vector3d& a_, const Vector3d& b_, const Vector3d& c_)
      : a(a_), b(b_), c(c_), centroid((a + b + c) / 3.0), area_normal(0.5 * (b - a).cross(c - a)) {}
  Vector3d a, b, c;
  Vector3d centroid;
  Vector3d area_normal;  // area times unit normal
};

double segment_squared_distance(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  const double length2 = ab.squaredNorm();
  const double t = length2 > 0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).squaredNorm();
}

// Closest point by Voronoi regions of the vertices, edges and face (Ericson,
// Real-Time Collision Detection, 5.1.5); squared distance returned.
double triangle_squared_distance(const Vector3d& p, const Triangle& t) {
  const Vector3d ab = t.b - t.a, ac = t.c - t.a, ap = p - t.a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return ap.squaredNorm();
  const Vector3d bp = p - t.b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return bp.squaredNorm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (ap - (d1 / (d1 - d3)) * ab).squaredNorm();
  const Vector3d cp = p - t.c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return cp.squaredNorm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (ap - (d2 / (d2 - d6)) * ac).squaredNorm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return (bp - w * (t.c - t.b)).squaredNorm();
  }
  const double sum = va + vb + vc;
  if (!(sum > 0))  // degenerate (zero-area) triangle
    return std::min({segment_squared_distance(p, t.a, t.b), segment_squared_distance(p, t.b, t.c),
                     segment_squared_distance(p, t.c, t.a)});
  return (ap - (vb / sum) * ab - (vc / sum) * ac).squaredNorm();
}

// Signed solid angle of the triangle seen from q, divided by 4 pi (Van Oosterom and
// Strackee 1983): tan(omega/2) = a.(b x c) / (|a||b||c| + (a.b)|c| + (b.c)|a| + (c.a)|b|).
double triangle_winding(const Vector3d& q, const Triangle& t) {
  const Vector3d a = t.a - q, b = t.b - q, c = t.c - q;
  const double la = a.norm(), lb = b.norm(), lc = c.norm();
  const double numerator = a.dot(b.cross(c));
  if (numerator == 0) return 0;  // q in the triangle's plane (or a degenerate triangle)
  const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
  return 2.0 * std::atan2(numerator, denominator) / kFourPi;
}

inline double box_squared_distance(const Eigen::AlignedBox3d& box, const Vector3d& p) {
  double sum = 0;
  for (int a = 0; a < 3; ++a) {
    const double gap = std::max({box.min()[a] - p[a], p[a] - box.max()[a], 0.0});
    sum += gap * gap;
  }
  return sum;
}

struct BvhNode {
  Eigen::AlignedBox3d box;
  int left = -1, right = -1;  // children; -1 for a leaf
  int begin = 0, end = 0;     // triangle range
  // Far-field expansion of the winding number of the node's triangles.
  Vector3d area_normal = Vector3d::Zero();           // sum of a_t n_t
  Vector3d center = Vector3d::Zero();                // area-weighted centroid
  Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();  // sum of a_t n_t (c_t - center)^T
  double radius = 0;                                 // farthest vertex from center
  bool is_leaf() const { return left < 0; }
};

class TriangleBvh {
 public:
  explicit TriangleBvh(std::vector<Triangle> triangles) : triangles_(std::move(triangles)) {
    nodes_.reserve(2 * triangles_.size() / kLeafSize + 16);
    build(0, int(triangles_.size()));
  }

  // Squared distance to the closest triangle. `hint` is a triangle index that is likely
  // close (the previous query's answer); it is updated.
  double squared_distance(const Vector3d& q, int& hint) const {
    double best = triangle_squared_distance(q, triangles_[hint]);
    struct Entry {
      int node;
      double box_distance2;
    } stack[128];
    int top = 0;
    stack[top++] = {0, box_squared_distance(nodes_[0].box, q)};
    while (top > 0) {
      const Entry entry = stack[--top];
      if (entry.box_distance2 >= best) continue;
      const BvhNode& node = nodes_[entry.node];
      if (node.is_leaf()) {
        for (int t = node.begin; t < node.end; ++t) {
          const double d = triangle_squared_distance(q, triangles_[t]);
          if (d < best) best = d, hint = t;
        }
        continue;
      }
      const Entry left{node.left, box_squared_distance(nodes_[node.left].box, q)};
      const Entry right{node.right, box_squared_distance(nodes_[node.right].box, q)};
      // Push the farther child first so that the nearer one is visited first.
      if (left.box_distance2 < right.box_distance2)
        stack[top++] = right, stack[top++] = left;
      else
        stack[top++] = left, stack[top++] = right;
    }
    return best;
  }

  double winding_number(const Vector3d& q) const {
    double w = 0;
    int stack[128], top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const BvhNode& node = nodes_[stack[--top]];
      const Vector3d r = node.center - q;
      const double r2 = r.squaredNorm();
      if (r2 > kFarFieldRatio * kFarFieldRatio * node.radius * node.radius) {
        w += far_field(node, r, r2);
      } else if (node.is_leaf()) {
        for (int t = node.begin; t < node.end; ++t) w += triangle_winding(q, triangles_[t]);
      } else {
        stack[top++] = node.left;
        stack[top++] = node.right;
      }
    }
    return w;
  }

 private:
  // Taylor expansion of sum_t a_t n_t . (x - q) / (4 pi |x - q|^3) about the node centre.
  static double far_field(const BvhNode& node, const Vector3d& r, double r2) {
    const double inv_r = 1.0 / std::sqrt(r2);
    const double inv_r3 = inv_r * inv_r * inv_r;
    const double dipole = node.area_normal.dot(r) * inv_r3;
    const double second =
        node.moment.trace() * inv_r3 - 3.0 * r.dot(node.moment * r) * inv_r3 * inv_r * inv_r;
    return (dipole + second) / kFourPi;
  }

  int build(int begin, int end) {
    const int id = int(nodes_.size());
    nodes_.emplace_back();
    fit(nodes_[id], begin, end);
    if (end - begin <= kLeafSize) return id;
    const int mid = split(begin, end);
    const int left = build(begin, mid);
    const int right = build(mid, end);
    nodes_[id].left = left;
    nodes_[id].right = right;
    return id;
  }

  // Median split along the longest axis of the centroids' box.
  int split(int begin, int end) {
    Eigen::AlignedBox3d centroids;
    for (int t = begin; t < end; ++t) centroids.extend(triangles_[t].centroid);
    int axis;
    centroids.sizes().maxCoeff(&axis);
    const int mid = (begin + end) / 2;
    std::nth_element(triangles_.begin() + begin, triangles_.begin() + mid, triangles_.begin() + end,
                     [axis](const Triangle& x, const Triangle& y) {
                       return x.centroid[axis] < y.centroid[axis];
                     });
    return mid;
  }

  void fit(BvhNode& node, int begin, int end) const {
    node.begin = begin;
    node.end = end;
    double area = 0;
    Vector3d weighted = Vector3d::Zero(), plain = Vector3d::Zero();
    for (int t = begin; t < end; ++t) {
      const Triangle& tri = triangles_[t];
      node.box.extend(tri.a).extend(tri.b).extend(tri.c);
      const double a = tri.area_normal.norm();
      area += a;
      weighted += a * tri.centroid;
      plain += tri.centroid;
      node.area_normal += tri.area_normal;
    }
    node.center = area > 0 ? Vector3d(weighted / area) : Vector3d(plain / (end - begin));
    for (int t = begin; t < end; ++t) {
      const Triangle& tri = triangles_[t];
      node.moment += tri.area_normal * (tri.centroid - node.center).transpose();
      for (const Vector3d* v : {&tri.a, &tri.b, &tri.c})
        node.radius = std::max(node.radius, (*v - node.center).norm());
    }
  }

  std::vector<Triangle> triangles_;
  std::vector<BvhNode> nodes_;
};

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw InputError(fmt::format("cannot turn mesh '{}' into an SDF: {}", source, what));
}

void validate_mesh(const TriangleMesh& mesh, const Transform& transform,
                   const std::string& source) {
  if (mesh.faces.empty()) fail(source, "it has no faces");
  if (!(transform.scale > 0) || !std::isfinite(transform.scale))
    fail(source, fmt::format("transform scale must be positive, got {}", transform.scale));
  const int n = int(mesh.vertices.size());
  for (std::size_t f = 0; f < mesh.faces.size(); ++f)
    for (int c = 0; c < 3; ++c)
      if (mesh.faces[f][c] < 0 || mesh.faces[f][c] >= n)
        fail(source, fmt::format("face {} refers to vertex {}, but there are {} vertices", f,
                                 mesh.faces[f][c], n));
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    if (!mesh.vertices[v].allFinite())
      fail(source, fmt::format("vertex {} has non-finite coordinates", v));
}

std::vector<Triangle> world_triangles(const TriangleMesh& mesh, const Transform& transform) {
  std::vector<Vector3d> world(mesh.vertices.size());
  for (std::size_t v = 0; v < world.size(); ++v) world[v] = transform.apply(mesh.vertices[v]);
  std::vector<Triangle> triangles(mesh.faces.size());
  for (std::size_t f = 0; f < triangles.size(); ++f) {
    const Eigen::Vector3i& face = mesh.faces[f];
    triangles[f] = Triangle(world[face[0]], world[face[1]], world[face[2]]);
  }
  return triangles;
}

SdfGrid place_grid(const std::vector<Triangle>& triangles, double cell_size, int border,
                   const std::string& source) {
  Eigen::AlignedBox3d bounds;
  for (const Triangle& t : triangles) bounds.extend(t.a).extend(t.b).extend(t.c);
  try {
    return make_grid_for_bounds(bounds, cell_size, border);
  } catch (const InputError& e) {
    fail(source, e.what());
  }
}

// The fraction of nodes away from the surface whose winding number is neither clearly
// inside (near 1) nor clearly outside (near 0).
double ambiguous_fraction(const SdfGrid& grid, const std::vector<float>& winding) {
  long far = 0, ambiguous = 0;
  for (std::size_t n = 0; n < winding.size(); ++n) {
    if (std::abs(grid.phi[n]) <= kAmbiguityMinDistanceCells * grid.cell_size) continue;
    ++far;
    if (winding[n] >= kAmbiguousLow && winding[n] <= kAmbiguousHigh) ++ambiguous;
  }
  return far > 0 ? double(ambiguous) / double(far) : 0.0;
}

void check_inside_is_defined(const SdfGrid& grid, const std::vector<float>& winding,
                             const std::string& source) {
  const double fraction = ambiguous_fraction(grid, winding);
  if (fraction > kMaxAmbiguousFraction)
    fail(source,
         fmt::format("the mesh is not closed enough to define an inside: {:.1f}% of the grid "
                     "nodes farther than {} cells from the surface have a winding number "
                     "between {} and {} (at most {:.0f}% allowed). Close the holes (e.g. with "
                     "MeshLab's Close Holes filter), make the faces consistently "
                     "oriented, or supply an .sdf file instead",
                     100.0 * fraction, kAmbiguityMinDistanceCells, kAmbiguousLow, kAmbiguousHigh,
                     100.0 * kMaxAmbiguousFraction));
  if (std::none_of(grid.phi.begin(), grid.phi.end(), [](double v) { return v < 0; }))
    fail(source,
         fmt::format("no grid node is inside the mesh (cell_size {} m). The faces may be "
                     "oriented inwards (flip the normals), or the shape is thinner than a cell "
                     "(lower cell_size)",
                     grid.cell_size));
}

// Sets every node's phi and returns its winding number. Consecutive nodes along x are
// close, so each thread starts a node's search from the previous node's closest triangle.
std::vector<float> fill_signed_distances(const TriangleBvh& bvh, SdfGrid& grid) {
  const long count = grid.node_count();
  std::vector<float> winding(count);
#pragma omp parallel
  {
    int hint = 0;
#pragma omp for schedule(dynamic, 256)
    for (long n = 0; n < count; ++n) {
      const Vector3d q = grid.node_position(n);
      const double distance = std::sqrt(bvh.squared_distance(q, hint));
      const double w = bvh.winding_number(q);
      winding[n] = float(w);
      grid.phi[n] = w > 0.5 ? -distance : distance;
    }
  }
  return winding;
}

}  // namespace

SdfGrid mesh_to_sdf(const TriangleMesh& mesh, const Transform& transform, double cell_size,
                    int border_cells, const std::string& source_name) {
  validate_mesh(mesh, transform, source_name);
  std::vector<Triangle> triangles = world_triangles(mesh, transform);
  SdfGrid grid = place_grid(triangles, cell_size, border_cells, source_name);
  const TriangleBvh bvh(std::move(triangles));

  const std::vector<float> winding = fill_signed_distances(bvh, grid);
  check_inside_is_defined(grid, winding, source_name);
  return grid;
}

std::vector<double> winding_numbers(const TriangleMesh& mesh,
                                    const std::vector<Eigen::Vector3d>& points, bool exact) {
  validate_mesh(mesh, Transform{}, "winding_numbers");
  const std::vector<Triangle> triangles = world_triangles(mesh, Transform{});
  const TriangleBvh bvh(triangles);
  std::vector<double> w(points.size());
#pragma omp parallel for schedule(dynamic, 16)
  for (long p = 0; p < long(points.size()); ++p) {
    if (!exact) {
      w[p] = bvh.winding_number(points[p]);
      continue;
    }
    double sum = 0;
    for (const Triangle& t : triangles) sum += triangle_winding(points[p], t);
    w[p] = sum;
  }
  return w;
}

}  // namespace ssc
