// Rest-shape construction from primitives, .sdf files and meshes (see body.h).
#include "models/sim/body.h"

#include <fmt/format.h>

#include "models/geometry/mesh.h"
#include "models/geometry/mesh_sdf.h"
#include "models/geometry/primitives.h"
#include "models/geometry/sdf_file.h"
#include "runtime/errors.h"
#include "models/io/run_record.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace ssc {

static double resolve_cell_size(const Scene& scene, const Eigen::AlignedBox3d& bounds) {
  if (scene.cell_size > 0) return scene.cell_size;
  const int resolution = int(-scene.cell_size);
  return bounds.sizes().maxCoeff() / resolution;
}

// A rotated object's grid is laid along its own axes from its own origin; an unrotated one's is
// the world's (the same axes). A body held by dirichlet boxes keeps the world's: the engine
// holds fixed nodes at zero displacement.
static bool grid_in_object_frame(const Scene& scene) {
  return scene.grid_in_object_frame && scene.object.kind != ObjectSpec::Kind::SdfFile &&
         scene.object.transform.rotation_deg.norm() != 0 && scene.dirichlet.empty();
}

RestPose initial_pose(const Scene& scene) {
  RestPose pose;
  if (!grid_in_object_frame(scene)) return pose;
  pose.rotation = scene.object.transform.rotation();
  pose.translation = scene.object.transform.position;
  return pose;
}

// The object as the grid holds it: in its own frame (scaled), its position and rotation left
// to the initial pose.
static ObjectSpec object_in_grid_frame(const Scene& scene) {
  ObjectSpec o = scene.object;
  if (!grid_in_object_frame(scene)) return o;
  o.transform.rotation_deg.setZero();
  o.transform.position.setZero();
  o.primitive.transform = o.transform;
  return o;
}

static SdfGrid build_rest_sdf_unnamed(const Scene& scene) {
  const ObjectSpec o = object_in_grid_frame(scene);
  switch (o.kind) {
    case ObjectSpec::Kind::Primitive:
      return sample_primitive(o.primitive, resolve_cell_size(scene, primitive_bounds(o.primitive)), kGridBorderCells);
    case ObjectSpec::Kind::SdfFile:
      return load_sdf_file(o.path, o.transform.scale, o.transform.position);
    case ObjectSpec::Kind::Mesh: {
      const TriangleMesh mesh = load_mesh(o.path);
      Eigen::AlignedBox3d bounds;
      for (const Eigen::Vector3d& v : mesh.vertices) bounds.extend(o.transform.apply(v));
      return mesh_to_sdf(mesh, o.transform, resolve_cell_size(scene, bounds), kGridBorderCells, o.path);
    }
  }
  throw InputError(scene.file + ": unknown object kind");
}

SdfGrid build_rest_sdf(const Scene& scene) {
  try {
    return build_rest_sdf_unnamed(scene);
  } catch (const InputError& e) {
    const std::string what = e.what();
    if (what.rfind(scene.file, 0) == 0 || (!scene.object.path.empty() && what.find(scene.object.path) != std::string::npos)) throw;
    throw InputError(scene.file + ": " + what);  // name the scene the grid comes from
  }
}

double primitive_volume(const Primitive& p) {
  constexpr double kPi = 3.14159265358979323846;
  const double s3 = std::pow(p.transform.scale, 3);
  switch (p.type) {
    case PrimitiveType::Sphere:
      return s3 * 4.0 / 3.0 * kPi * std::pow(p.radius, 3);
    case PrimitiveType::Box:
      return s3 * 8 * p.half_extents.prod();
    case PrimitiveType::Torus:
      return s3 * 2 * kPi * kPi * p.major_radius * p.minor_radius * p.minor_radius;
    case PrimitiveType::Capsule:
      return s3 * (kPi * p.radius * p.radius * 2 * p.half_length + 4.0 / 3.0 * kPi * std::pow(p.radius, 3));
  }
  return 0;
}

// The enclosed volume of a closed, consistently wound mesh (divergence theorem), else 0;
// *boundary counts the edges of one face only (an open mesh).
static double closed_mesh_volume(const TriangleMesh& mesh, double scale, int* boundary) {
  std::map<std::pair<int, int>, int> undirected, directed;
  double v = 0;
  for (const Eigen::Vector3i& f : mesh.faces) {
    for (int e = 0; e < 3; ++e) {
      ++undirected[std::minmax(f[e], f[(e + 1) % 3])];
      ++directed[{f[e], f[(e + 1) % 3]}];
    }
    v += mesh.vertices[f[0]].dot(mesh.vertices[f[1]].cross(mesh.vertices[f[2]])) / 6;
  }
  *boundary = 0;
  for (const auto& [edge, count] : undirected) *boundary += count == 1;
  bool consistent = true;
  for (const auto& [edge, count] : directed) consistent &= count == 1 && directed.count({edge.second, edge.first}) == 1;
  return *boundary > 0 || !consistent ? 0 : std::abs(v) * std::pow(scale, 3);
}

void assign_material_regions(const Scene& scene, SimGrid& grid) {
  const std::vector<MaterialRegion>& regions = scene.material.regions;
  const int R = int(regions.size());
  grid.region_count = {R};
  grid.cell_region_share.assign(size_t(R) * size_t(grid.cell_count), 0.0);
  if (R == 0) return;
  // The region of a point: the last that contains it, -1 for none.
  auto region_of = [&](const Eigen::Vector3d& x) {
    int r = -1;
    for (int k = 0; k < R; ++k)
      if (regions[size_t(k)].contains(x)) r = k;
    return r;
  };
  const SdfGrid& sdf = grid.sdf;
  const long nx = sdf.size.x(), nxy = nx * sdf.size.y();
  std::vector<double> share(size_t(R) + 1);
  std::vector<double> held(size_t(R), 0.0);
  for (int e = 0; e < grid.cell_count; ++e) {
    const long o = grid.cell_origin[e];
    const Eigen::Vector3d corner0 = sdf.node_position(o);
    double phi[8];
    for (int c = 0; c < 8; ++c) phi[c] = sdf.phi[size_t(o + (c & 1) + ((c >> 1) & 1) * nx + ((c >> 2) & 1) * nxy)];
    std::fill(share.begin(), share.end(), 0.0);
    int inside = 0;
    for (int a = 0; a < kRegionSamples; ++a)
      for (int b = 0; b < kRegionSamples; ++b)
        for (int d = 0; d < kRegionSamples; ++d) {
          const Eigen::Vector3d t = (Eigen::Vector3d(a, b, d) + Eigen::Vector3d::Constant(0.5)) / kRegionSamples;
          double value = 0;
          for (int c = 0; c < 8; ++c)
            value += phi[c] * ((c & 1) ? t.x() : 1 - t.x()) * (((c >> 1) & 1) ? t.y() : 1 - t.y()) *
                     (((c >> 2) & 1) ? t.z() : 1 - t.z());
          if (value > 0) continue;
          ++inside;
          share[size_t(region_of(grid.start(corner0 + sdf.cell_size * t)) + 1)] += 1;
        }
    if (inside == 0) {  // a sliver of a cut cell between the samples: its centroid decides
      const Eigen::Vector3d x(grid.cell_center[3 * e], grid.cell_center[3 * e + 1], grid.cell_center[3 * e + 2]);
      share[size_t(region_of(grid.start(x)) + 1)] = inside = 1;
    }
    for (int k = 0; k < R; ++k) {
      grid.cell_region_share[size_t(R) * e + k] = share[size_t(k) + 1] / inside;
      held[size_t(k)] += share[size_t(k) + 1] / inside;
    }
  }
  for (int k = 0; k < R; ++k)
    if (held[size_t(k)] == 0)
      warn("empty_region", fmt::format("{}: material.regions[{}] holds no part of the body's cells (a cell's share "
                                       "of a region is the fraction of its inside part there, later regions first); "
                                       "its youngs_modulus has no effect",
                                       scene.file, k));
}

// A mesh exported in millimetres reads as a body of tens of metres or more: said before the
// grid is built, since what goes wrong then (a grid too large, a body inside the ground) does
// not point at the unit.
static void check_mesh_size(const Scene& scene, const TriangleMesh& mesh) {
  if (mesh.vertices.empty()) return;
  Eigen::Vector3d lo = mesh.vertices[0], hi = mesh.vertices[0];
  for (const Eigen::Vector3d& v : mesh.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  const double extent = scene.object.transform.scale * (hi - lo).maxCoeff();
  if (extent >= kMillimetreMeshExtent)
    warn("mesh_size", fmt::format("{}: the body is {:.4g} m across (object.scale {}): a mesh in millimetres reads as "
                                  "metres; if it is one, set object.scale to {:.4g} (scale 0.001?)",
                                  scene.object.path, extent, scene.object.transform.scale,
                                  0.001 * scene.object.transform.scale));
}

SimGrid build_body_grid(const Scene& scene) {
  const std::string source = scene.object.path.empty() ? scene.file + ": object" : scene.object.path;
  TriangleMesh mesh;
  if (scene.object.kind == ObjectSpec::Kind::Mesh) {
    mesh = load_mesh(scene.object.path);
    check_mesh_size(scene, mesh);
  }
  RestSurface exact;  // primitives: their exact distance places the contact points (sim_grid.h)
  if (scene.object.kind == ObjectSpec::Kind::Primitive) {
    const Primitive primitive = object_in_grid_frame(scene).primitive;
    exact = [primitive](const Eigen::Vector3d& x) { return primitive_sdf(primitive, x); };
  }
  SimGrid grid = build_sim_grid(build_rest_sdf(scene), scene.grid, source, exact);
  grid.pose = initial_pose(scene);
  // The stiffness gradient is given in the world: each cell's offset from the centre of mass
  // as it starts.
  for (int e = 0; e < grid.cell_count; ++e) {
    const Eigen::Vector3d o = grid.pose.rotation * Eigen::Vector3d(grid.cell_offset[3 * e], grid.cell_offset[3 * e + 1], grid.cell_offset[3 * e + 2]);
    for (int k = 0; k < 3; ++k) grid.cell_offset[3 * size_t(e) + k] = o[k];
  }
  assign_material_regions(scene, grid);
  double reference = 0;
  if (scene.object.kind == ObjectSpec::Kind::Primitive) reference = primitive_volume(scene.object.primitive);
  if (scene.object.kind == ObjectSpec::Kind::Mesh) {
    int boundary = 0;
    reference = closed_mesh_volume(mesh, scene.object.transform.scale, &boundary);
    if (boundary > 0)
      warn("open_mesh", fmt::format("{}: the mesh is open ({} edges belong to one face only); its inside is inferred from "
                                    "winding numbers, which fills small holes of a scan but guesses across large ones. "
                                    "The body holds {:.4g} m^3: check it, or close the mesh",
                                    scene.object.path, boundary, grid.total_volume));
  }
  if (reference > 0) {
    const double lost = 1 - grid.total_volume / reference;
    const std::string what = fmt::format(
        "{}: the simulation grid (cell size {:.3g} m) holds {:.1f} % of the object's volume ({:.4g} of {:.4g} m^3): "
        "the cells are too coarse for the shape",
        scene.file, grid.h, 100 * grid.total_volume / reference, grid.total_volume, reference);
    if (lost > kVolumeLossError)
      throw InputError(what + fmt::format("; the mass and stiffness would be wrong. Lower grid.cell_size or raise grid.resolution "
                                          "(ssc refuses a grid that loses more than {:.0f} %)", 100 * kVolumeLossError));
    if (std::abs(lost) > kVolumeLossWarning)
      warn("grid_volume", what + "; masses are off by as much. Lower grid.cell_size or raise grid.resolution");
  }
  return grid;
}

}  // namespace ssc
