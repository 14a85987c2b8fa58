#include "models/geometry/primitives.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>

#include "models/geometry/grid_placement.h"
#include "runtime/errors.h"

namespace ssc {

namespace {

using Eigen::Vector3d;

double sphere_sdf(const Vector3d& p, double radius) { return p.norm() - radius; }

double box_sdf(const Vector3d& p, const Vector3d& half_extents) {
  const Vector3d q = p.cwiseAbs() - half_extents;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

double torus_sdf(const Vector3d& p, double major_radius, double minor_radius) {
  const double ring = std::hypot(p.x(), p.z()) - major_radius;
  return std::hypot(ring, p.y()) - minor_radius;
}

double capsule_sdf(const Vector3d& p, double half_length, double radius) {
  const double y = std::clamp(p.y(), -half_length, half_length);
  return (p - Vector3d(0, y, 0)).norm() - radius;
}

double local_sdf(const Primitive& s, const Vector3d& p) {
  switch (s.type) {
    case PrimitiveType::Sphere:
      return sphere_sdf(p, s.radius);
    case PrimitiveType::Box:
      return box_sdf(p, s.half_extents);
    case PrimitiveType::Torus:
      return torus_sdf(p, s.major_radius, s.minor_radius);
    case PrimitiveType::Capsule:
      return capsule_sdf(p, s.half_length, s.radius);
  }
  return 0;
}

Vector3d local_half_size(const Primitive& s) {
  switch (s.type) {
    case PrimitiveType::Sphere:
      return Vector3d::Constant(s.radius);
    case PrimitiveType::Box:
      return s.half_extents;
    case PrimitiveType::Torus: {
      const double outer = s.major_radius + s.minor_radius;
      return {outer, s.minor_radius, outer};
    }
    case PrimitiveType::Capsule:
      return {s.radius, s.half_length + s.radius, s.radius};
  }
  return Vector3d::Zero();
}

void require_positive(double value, const char* key, const Primitive& s) {
  if (!(value > 0) || !std::isfinite(value))
    throw InputError(fmt::format("{} {} must be a positive finite number, got {}",
                                 primitive_type_name(s.type), key, value));
}

void validate(const Primitive& s) {
  require_positive(s.transform.scale, "transform scale", s);
  switch (s.type) {
    case PrimitiveType::Sphere:
      require_positive(s.radius, "radius", s);
      break;
    case PrimitiveType::Box:
      for (int a = 0; a < 3; ++a) require_positive(s.half_extents[a], "half_extents", s);
      break;
    case PrimitiveType::Torus:
      require_positive(s.major_radius, "major_radius", s);
      require_positive(s.minor_radius, "minor_radius", s);
      break;
    case PrimitiveType::Capsule:
      require_positive(s.radius, "radius", s);
      if (!(s.half_length >= 0))
        throw InputError(fmt::format("capsule half_length must be >= 0, got {}", s.half_length));
      break;
  }
}

}  // namespace

PrimitiveType parse_primitive_type(const std::string& name) {
  std::string lower = name;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  if (lower == "sphere") return PrimitiveType::Sphere;
  if (lower == "box") return PrimitiveType::Box;
  if (lower == "torus") return PrimitiveType::Torus;
  if (lower == "capsule") return PrimitiveType::Capsule;
  throw InputError(fmt::format(
      "unknown primitive type '{}'; valid types are: sphere, box, torus, capsule", name));
}

std::string primitive_type_name(PrimitiveType type) {
  switch (type) {
    case PrimitiveType::Sphere:
      return "sphere";
    case PrimitiveType::Box:
      return "box";
    case PrimitiveType::Torus:
      return "torus";
    case PrimitiveType::Capsule:
      return "capsule";
  }
  return "unknown";
}

double primitive_sdf(const Primitive& primitive, const Eigen::Vector3d& world) {
  const Vector3d local = primitive.transform.to_local(world);
  return primitive.transform.scale * local_sdf(primitive, local);
}

Eigen::AlignedBox3d primitive_bounds(const Primitive& primitive) {
  const Eigen::AlignedBox3d local(-local_half_size(primitive), local_half_size(primitive));
  Eigen::AlignedBox3d world;
  for (int c = 0; c < 8; ++c)
    world.extend(primitive.transform.apply(local.corner(Eigen::AlignedBox3d::CornerType(c))));
  return world;
}

SdfGrid sample_primitive(const Primitive& primitive, double cell_size, int border_cells) {
  validate(primitive);
  SdfGrid grid = make_grid_for_bounds(primitive_bounds(primitive), cell_size, border_cells);
  const int nx = grid.size.x(), ny = grid.size.y(), nz = grid.size.z();
#pragma omp parallel for collapse(2) schedule(static)
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        grid.phi[grid.index(i, j, k)] = primitive_sdf(primitive, grid.node_position(i, j, k));
  return grid;
}

}  // namespace ssc
