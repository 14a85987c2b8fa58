// Rest-shape construction from primitives, .sdf files and meshes (see body.h).
#include "models/sim/body.h"

#include <fmt/format.h>

#include "models/geometry/mesh.h"
#include "models/geometry/mesh_sdf.h"
#include "models/geometry/primitives.h"
#include "models/geometry/sdf_file.h"
#include "models/io/errors.h"

namespace ssc {

static double resolve_cell_size(const Scene& scene, const Eigen::AlignedBox3d& bounds) {
  if (scene.cell_size > 0) return scene.cell_size;
  const int resolution = int(-scene.cell_size);
  return bounds.sizes().maxCoeff() / resolution;
}

SdfGrid build_rest_sdf(const Scene& scene) {
  const ObjectSpec& o = scene.object;
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

SimGrid build_body_grid(const Scene& scene) {
  const std::string source = scene.object.path.empty() ? scene.file + ": object" : scene.object.path;
  return build_sim_grid(build_rest_sdf(scene), scene.grid, source);
}

}  // namespace ssc
