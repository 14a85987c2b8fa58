// Analytic shapes (sphere, box, torus, capsule) with exact Euclidean signed distances,
// placed in the world by a Transform. Shapes are defined in local coordinates centred at
// the origin: the torus ring lies in the local xz-plane around the +y axis, the capsule's
// segment runs along local y from -half_length to +half_length. The transform's uniform
// scale multiplies all distances.
#pragma once
#include <Eigen/Geometry>
#include <string>

#include "models/geometry/sdf_grid.h"
#include "models/geometry/transform.h"

namespace ssc {

enum class PrimitiveType { Sphere, Box, Torus, Capsule };

struct Primitive {
  PrimitiveType type = PrimitiveType::Sphere;
  double radius = 0.5;                             // sphere, capsule
  Eigen::Vector3d half_extents{0.5, 0.5, 0.5};     // box
  double major_radius = 1.0, minor_radius = 0.25;  // torus
  double half_length = 0.5;                        // capsule
  Transform transform;
};

// "sphere", "box", "torus" or "capsule" (case-insensitive).
PrimitiveType parse_primitive_type(const std::string& name);
std::string primitive_type_name(PrimitiveType type);

// Signed distance in metres of a world point to the shape, negative inside.
double primitive_sdf(const Primitive& primitive, const Eigen::Vector3d& world);

// A world-space box containing the shape (not necessarily tight when rotated).
Eigen::AlignedBox3d primitive_bounds(const Primitive& primitive);

// The shape sampled on a grid placed with make_grid_for_bounds.
SdfGrid sample_primitive(const Primitive& primitive, double cell_size, int border_cells);

}  // namespace ssc
