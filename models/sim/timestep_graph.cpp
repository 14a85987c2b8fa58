// Builds the forward graph of one timestep (see timestep_graph.h).
#include "models/sim/timestep_graph.h"

#include "models/sim/scene.h"

namespace ssc {

TimestepModel timestep_model(const Scene& scene) {
  TimestepModel m;
  m.friction = models_friction(scene);
  m.region_count = int(scene.material.regions.size());
  m.stiffness_gradient = scene.material.stiffness_gradient_key;
  m.air_drag = scene.air_drag_key;
  return m;
}

TimestepGraph build_timestep_graph(int plane_count, bool extension, const TimestepModel& model) {
  TimestepGraph t;
  Graph& g = t.graph;
  using D = Domain;
  using A = Access;
  t.youngs_modulus = g.add_input("youngs_modulus", D::Scalar, 1);
  t.poisson_ratio = g.add_input("poisson_ratio", D::Scalar, 1);
  t.density = g.add_input("density", D::Scalar, 1);
  t.mass_damping = g.add_input("mass_damping", D::Scalar, 1);
  t.stiffness_damping = g.add_input("stiffness_damping", D::Scalar, 1);
  t.gravity = g.add_input("gravity", D::Scalar, 3);
  t.dt = g.add_input("dt", D::Scalar, 1);
  t.theta = g.add_input("theta", D::Scalar, 1);
  if (plane_count > 0) t.ground_planes = g.add_input("ground_planes", D::Scalar, 6 * plane_count);
  g.set_plane_count(plane_count);
  const bool friction = model.friction && plane_count > 0;
  const int friction_values = friction ? g.add_input("friction", D::Scalar, 2 * plane_count) : -1;
  t.fixed = g.add_input("fixed", D::Node, 1);
  t.u_prev = g.add_state("u_prev", D::Node, 3);
  t.v_prev = g.add_state("v_prev", D::Node, 3);

  auto P = [](const char* slot, int tensor) { return OpArg{slot, tensor, A::Pointwise}; };
  auto G = [](const char* slot, int tensor) { return OpArg{slot, tensor, A::Gather}; };

  // node_mass first, so that the cell ops from the Lame parameters to the corotation force
  // fuse into one kernel.
  g.add_op("node_mass", {P("density", t.density)}, {{"mass", "mass", D::Node, 1}});
  t.mass = g.find_tensor("mass");
  std::vector<OpArg> lame_inputs = {P("youngs_modulus", t.youngs_modulus), P("poisson_ratio", t.poisson_ratio)};
  if (model.heterogeneous()) {
    std::vector<OpArg> field_inputs = {P("youngs_modulus", t.youngs_modulus)};
    if (model.region_count > 0) {
      t.region_youngs = g.add_input("region_youngs", D::Scalar, model.region_count);
      field_inputs.push_back(P("region_youngs", t.region_youngs));
    }
    if (model.stiffness_gradient) {
      t.stiffness_gradient = g.add_input("stiffness_gradient", D::Scalar, 3);
      field_inputs.push_back(P("stiffness_gradient", t.stiffness_gradient));
    }
    g.add_op("stiffness_field", field_inputs, {{"cell_youngs", "cell_youngs", D::Cell, 1}});
    lame_inputs.push_back(P("cell_youngs", g.find_tensor("cell_youngs")));
  }
  g.add_op("lame", lame_inputs, {{"lambda", "lambda", D::Cell, 1}, {"mu", "mu", D::Cell, 1}});
  t.lambda = g.find_tensor("lambda");
  t.mu = g.find_tensor("mu");
  g.add_op("corotation", {G("u_prev", t.u_prev)},
           {{"rotation", "rotation", D::Cell, 9}, {"polar_status", "polar_status", D::Cell, 1}});
  t.rotation = g.find_tensor("rotation");
  g.add_op("corotation_force", {P("rotation", t.rotation), P("lambda", t.lambda), P("mu", t.mu)},
           {{"corner_force", "corotation_force", D::Cell, 24}});
  std::vector<OpArg> force_inputs = {G("corner_force", g.find_tensor("corotation_force")), P("mass", t.mass),
                                     P("gravity", t.gravity)};
  if (plane_count > 0) {
    g.add_op("contact_force",
             {G("u_prev", t.u_prev), G("v_prev", t.v_prev), P("ground_planes", t.ground_planes), P("dt", t.dt),
              P("theta", t.theta)},
             {{"point_force", "contact_force", D::Point, 3}});
    int point_force = g.find_tensor("contact_force");
    if (friction) {
      g.add_op("friction",
               {G("u_prev", t.u_prev), G("v_prev", t.v_prev), P("ground_planes", t.ground_planes),
                P("friction", friction_values), P("contact_force", point_force)},
               {{"point_force", "contact_friction_force", D::Point, 3}, {"damping", "friction_damping", D::Node, 6}});
      point_force = g.find_tensor("contact_friction_force");
    }
    force_inputs.push_back(G("point_force", point_force));
  }
  int damping = g.find_tensor("friction_damping");
  if (model.air_drag) {
    t.air_drag = g.add_input("air_drag", D::Scalar, 1);
    std::vector<OpArg> drag_inputs = {P("air_drag", t.air_drag), P("v_prev", t.v_prev), G("rotation", t.rotation)};
    if (damping >= 0) drag_inputs.push_back(P("damping_in", damping));
    g.add_op("air_drag", drag_inputs, {{"drag_force", "drag_force", D::Node, 3}, {"damping", "drag_damping", D::Node, 6}});
    damping = g.find_tensor("drag_damping");
    force_inputs.push_back(P("body_force", g.find_tensor("drag_force")));
  }
  g.add_op("node_force", force_inputs, {{"force", "force", D::Node, 3}});
  g.add_op("stiffness_apply",
           {P("rotation", t.rotation), P("lambda", t.lambda), P("mu", t.mu), G("u_prev", t.u_prev)},
           {{"ku_corner", "k_u_prev", D::Cell, 24}});
  const std::vector<OpArg> newmark_scalars = {P("dt", t.dt), P("theta", t.theta), P("mass_damping", t.mass_damping),
                                              P("stiffness_damping", t.stiffness_damping)};
  std::vector<OpArg> rhs_inputs = {G("ku_corner", g.find_tensor("k_u_prev")), P("mass", t.mass), P("u_prev", t.u_prev),
                                   P("v_prev", t.v_prev), P("force", g.find_tensor("force"))};
  if (damping >= 0) rhs_inputs.push_back(P("damping", damping));
  rhs_inputs.insert(rhs_inputs.end(), newmark_scalars.begin(), newmark_scalars.end());
  g.add_op("newmark_rhs", rhs_inputs, {{"rhs", "rhs", D::Node, 3}});
  std::vector<OpArg> solve_inputs = {OpArg{"rotation", t.rotation, A::Opaque}, P("lambda", t.lambda), P("mu", t.mu),
                                     OpArg{"mass", t.mass, A::Opaque},         OpArg{"rhs", g.find_tensor("rhs"), A::Opaque},
                                     OpArg{"u_prev", t.u_prev, A::Opaque},     OpArg{"v_prev", t.v_prev, A::Opaque},
                                     OpArg{"fixed", t.fixed, A::Opaque}};
  if (damping >= 0) solve_inputs.push_back(OpArg{"damping", damping, A::Opaque});
  solve_inputs.insert(solve_inputs.end(), newmark_scalars.begin(), newmark_scalars.end());
  g.add_op("newmark_solve", solve_inputs,
           {{"u", "u", D::Node, 3}, {"cg_iterations", "cg_iterations", D::Scalar, 1}});
  t.u = g.find_tensor("u");
  t.cg_iterations = g.find_tensor("cg_iterations");
  g.add_op("velocity_update",
           {P("u", t.u), P("u_prev", t.u_prev), P("v_prev", t.v_prev), P("dt", t.dt), P("theta", t.theta)},
           {{"v", "v", D::Node, 3}});
  t.v = g.find_tensor("v");
  if (extension) {
    t.band_guess = g.add_state("band_guess", D::Band, 3);
    g.add_op("extension_solve", {G("u", t.u), OpArg{"band_guess", t.band_guess, A::Opaque}},
             {{"band_u", "band_u", D::Band, 3}});
    t.band_u = g.find_tensor("band_u");
  }
  g.validate();
  return t;
}

}  // namespace ssc
