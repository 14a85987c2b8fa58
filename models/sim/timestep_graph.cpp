// Builds the forward graph of one timestep (see timestep_graph.h).
#include "models/sim/timestep_graph.h"

namespace ssc {

TimestepGraph build_timestep_graph(int plane_count, bool extension, bool friction) {
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
  friction = friction && plane_count > 0;
  const int friction_values = friction ? g.add_input("friction", D::Scalar, 2 * plane_count) : -1;
  t.fixed = g.add_input("fixed", D::Node, 1);
  t.u_prev = g.add_state("u_prev", D::Node, 3);
  t.v_prev = g.add_state("v_prev", D::Node, 3);

  auto P = [](const char* slot, int tensor) { return OpArg{slot, tensor, A::Pointwise}; };
  auto G = [](const char* slot, int tensor) { return OpArg{slot, tensor, A::Gather}; };

  g.add_op("lame", {P("youngs_modulus", t.youngs_modulus), P("poisson_ratio", t.poisson_ratio)},
           {{"lambda", "lambda", D::Scalar, 1}, {"mu", "mu", D::Scalar, 1}});
  t.lambda = g.find_tensor("lambda");
  t.mu = g.find_tensor("mu");
  g.add_op("node_mass", {P("density", t.density)}, {{"mass", "mass", D::Node, 1}});
  t.mass = g.find_tensor("mass");
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
  const int damping = g.find_tensor("friction_damping");
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
