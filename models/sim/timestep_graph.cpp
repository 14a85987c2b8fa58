// Builds the forward graph of one timestep (see timestep_graph.h).
#include "models/sim/timestep_graph.h"

#include "models/sim/scene.h"
#include "ops/line_search.h"

namespace ssc {

TimestepModel timestep_model(const Scene& scene) {
  TimestepModel m;
  m.friction = models_friction(scene);
  m.region_count = int(scene.material.regions.size());
  m.stiffness_gradient = scene.material.stiffness_gradient_key;
  m.air_drag = scene.air_drag_key;
  m.implicit_contact = scene.solver.implicit_contact;
  m.neo_hookean = scene.material.neo_hookean;
  m.updated_corotation = scene.solver.updated_corotation;
  m.nonlinear_iterations = scene.solver.nonlinear_iterations;
  m.line_search = scene.solver.line_search;
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
  // The elastic terms of the start-of-step rotation (one cell kernel with the ops above); an
  // updated rotation adds the end's in each iteration.
  if (!model.neo_hookean) {
    g.add_op("corotation_force", {P("rotation", t.rotation), P("lambda", t.lambda), P("mu", t.mu)},
             {{"corner_force", "corotation_force", D::Cell, 24}});
    g.add_op("stiffness_apply", {P("rotation", t.rotation), P("lambda", t.lambda), P("mu", t.mu), G("u_prev", t.u_prev)},
             {{"ku_corner", "k_u_prev", D::Cell, 24}});
  }

  // Forces evaluated once, at the start of the step: the paper's contact (unless the contact
  // is implicit), friction, air drag. Each passes on the node-local matrix C it adds to
  // (damping) and the forces it adds to (point forces, node forces).
  const bool implicit_contact = model.implicit_contact && plane_count > 0;
  int point_force = -1, damping = -1, body_force = -1;
  if (plane_count > 0 && !implicit_contact) {
    g.add_op("contact_force",
             {G("u_prev", t.u_prev), G("v_prev", t.v_prev), P("ground_planes", t.ground_planes), P("dt", t.dt),
              P("theta", t.theta)},
             {{"point_force", "contact_force", D::Point, 3}});
    point_force = g.find_tensor("contact_force");
  }
  if (friction) {
    std::vector<OpArg> in = {G("u_prev", t.u_prev), G("v_prev", t.v_prev), P("ground_planes", t.ground_planes),
                             P("friction", friction_values)};
    if (point_force >= 0) in.push_back(P("contact_force", point_force));
    g.add_op("friction", in,
             {{"point_force", "contact_friction_force", D::Point, 3}, {"damping", "friction_damping", D::Node, 6}});
    point_force = g.find_tensor("contact_friction_force");
    damping = g.find_tensor("friction_damping");
  }
  if (model.air_drag) {
    t.air_drag = g.add_input("air_drag", D::Scalar, 1);
    std::vector<OpArg> in = {P("air_drag", t.air_drag), P("v_prev", t.v_prev), G("rotation", t.rotation)};
    if (damping >= 0) in.push_back(P("damping_in", damping));
    g.add_op("air_drag", in, {{"drag_force", "drag_force", D::Node, 3}, {"damping", "drag_damping", D::Node, 6}});
    damping = g.find_tensor("drag_damping");
    body_force = g.find_tensor("drag_force");
  }

  // The step's solve, repeated (ops/contact_implicit.h): iteration k evaluates the implicit
  // contact at the iterate u_k (the first: the prediction u- + dt v-) and (solver.corotation =
  // "updated") the rotation at u_k (at its theta-point for the Neo-Hookean material), starts
  // its CG iterations from u_k, and (implicit contact) line-searches the solve's step.
  const std::vector<OpArg> newmark_scalars = {P("dt", t.dt), P("theta", t.theta), P("mass_damping", t.mass_damping),
                                              P("stiffness_damping", t.stiffness_damping)};
  t.neo_hookean = model.neo_hookean;
  const bool iterating = model.iterates(plane_count);
  const int iterations = iterating ? std::max(1, model.nonlinear_iterations) : 1;
  int rotation = t.rotation, iterate = -1;
  const int corner_force = g.find_tensor("corotation_force");
  int ku = g.find_tensor("k_u_prev");
  for (int k = 0; k < iterations; ++k) {
    const bool last = k == iterations - 1;
    auto name = [k](const std::string& base) { return k == 0 ? base : base + "_it" + std::to_string(k); };
    int guess = -1, u_theta = -1, offset = -1;
    if (iterating) {
      std::vector<OpArg> in = {P("u_prev", t.u_prev), P("v_prev", t.v_prev), P("dt", t.dt), P("theta", t.theta)};
      if (iterate >= 0) in.push_back(P("u_iter", iterate));
      g.add_op("step_iterate", in,
               {{"guess", name("guess"), D::Node, 3}, {"u_theta", name("u_theta"), D::Node, 3},
                {"offset", name("offset"), D::Node, 3}});
      guess = g.find_tensor(name("guess"));
      u_theta = g.find_tensor(name("u_theta"));
      offset = g.find_tensor(name("offset"));
    }
    if (model.updated_corotation) {  // Neo-Hookean's at the theta-point, the corotated's at the end
      g.add_op("corotation", {G("u_prev", model.neo_hookean ? u_theta : guess)},
               {{"rotation", "rotation_it" + std::to_string(k), D::Cell, 9},
                {"polar_status", "polar_status_it" + std::to_string(k), D::Cell, 1}});
      rotation = g.find_tensor("rotation_it" + std::to_string(k));
    }
    int lambda = t.lambda, mu = t.mu, step_corner_force = corner_force;
    if (model.neo_hookean) {  // the system's Lame parameters at the iterate (ops/neo_hookean.h)
      g.add_op("neo_hookean_system", {G("u_theta", u_theta), P("lambda", t.lambda), P("mu", t.mu)},
               {{"lambda_system", name("lambda_system"), D::Cell, 1}, {"mu_system", name("mu_system"), D::Cell, 1}});
      lambda = g.find_tensor(name("lambda_system"));
      mu = g.find_tensor(name("mu_system"));
      g.add_op("neo_hookean_correction",
               {G("u_theta", u_theta), P("rotation", rotation), P("lambda", t.lambda), P("mu", t.mu),
                P("lambda_system", lambda), P("mu_system", mu)},
               {{"corner_force", name("neo_hookean_force"), D::Cell, 24}});
      step_corner_force = g.find_tensor(name("neo_hookean_force"));
    }
    if (model.neo_hookean || model.updated_corotation) {
      g.add_op("stiffness_apply", {P("rotation", rotation), P("lambda", lambda), P("mu", mu), G("u_prev", t.u_prev)},
               {{"ku_corner", name("end_k_u_prev"), D::Cell, 24}});
      ku = g.find_tensor(name("end_k_u_prev"));
    }
    if (model.updated_corotation && !model.neo_hookean) {  // each end of the step at its own rotation
      g.add_op("corotation_force", {P("rotation", rotation), P("lambda", t.lambda), P("mu", t.mu)},
               {{"corner_force", name("end_corotation_force"), D::Cell, 24}});
      g.add_op("theta_elastic_force",
               {P("theta", t.theta), P("start_force", corner_force), P("start_ku", g.find_tensor("k_u_prev")),
                P("end_force", g.find_tensor(name("end_corotation_force"))), P("end_ku", ku)},
               {{"corner_force", name("elastic_force"), D::Cell, 24}});
      step_corner_force = g.find_tensor(name("elastic_force"));
    }
    int step_point_force = point_force, step_damping = damping, step_body_force = body_force;
    if (implicit_contact) {
      std::vector<OpArg> in = {G("guess", guess), P("offset", offset), P("ground_planes", t.ground_planes),
                               P("dt", t.dt)};
      if (point_force >= 0) in.push_back(P("point_force_in", point_force));
      if (damping >= 0) in.push_back(P("damping_in", damping));
      if (body_force >= 0) in.push_back(P("force_in", body_force));
      g.add_op("contact_implicit", in,
               {{"point_force", name("contact_force"), D::Point, 3},
                {"damping", name("contact_damping"), D::Node, 6},
                {"node_force", name("contact_node_force"), D::Node, 3}});
      step_point_force = g.find_tensor(name("contact_force"));
      step_damping = g.find_tensor(name("contact_damping"));
      step_body_force = g.find_tensor(name("contact_node_force"));
    }
    std::vector<OpArg> force_inputs = {G("corner_force", step_corner_force), P("mass", t.mass), P("gravity", t.gravity)};
    if (step_point_force >= 0) force_inputs.push_back(G("point_force", step_point_force));
    if (step_body_force >= 0) force_inputs.push_back(P("body_force", step_body_force));
    g.add_op("node_force", force_inputs, {{"force", name("force"), D::Node, 3}});
    std::vector<OpArg> rhs_inputs = {G("ku_corner", ku), P("mass", t.mass), P("u_prev", t.u_prev),
                                     P("v_prev", t.v_prev), P("force", g.find_tensor(name("force")))};
    if (step_damping >= 0) rhs_inputs.push_back(P("damping", step_damping));
    rhs_inputs.insert(rhs_inputs.end(), newmark_scalars.begin(), newmark_scalars.end());
    g.add_op("newmark_rhs", rhs_inputs, {{"rhs", name("rhs"), D::Node, 3}});
    std::vector<OpArg> solve_inputs = {OpArg{"rotation", rotation, A::Opaque},  P("lambda", lambda), P("mu", mu),
                                       OpArg{"mass", t.mass, A::Opaque},        OpArg{"rhs", g.find_tensor(name("rhs")), A::Opaque},
                                       OpArg{"u_prev", t.u_prev, A::Opaque},    OpArg{"v_prev", t.v_prev, A::Opaque},
                                       OpArg{"fixed", t.fixed, A::Opaque}};
    if (step_damping >= 0) solve_inputs.push_back(OpArg{"damping", step_damping, A::Opaque});
    if (guess >= 0) solve_inputs.push_back(OpArg{"guess", guess, A::Opaque});
    if (!iterating) {  // a nonlinear iteration starts from its iterate, which also places the contact
      t.v_before = g.add_state("v_before", D::Node, 3);
      solve_inputs.push_back(OpArg{"v_before", t.v_before, A::Opaque});
    }
    solve_inputs.insert(solve_inputs.end(), newmark_scalars.begin(), newmark_scalars.end());
    const std::string u_name = last ? "u" : "u_it" + std::to_string(k + 1);
    const std::string cg_name = last ? "cg_iterations" : "cg_iterations_it" + std::to_string(k + 1);
    const bool line_search = implicit_contact && model.line_search;
    const std::string solved = line_search ? name("u_full") : u_name;
    g.add_op("newmark_solve", solve_inputs, {{"u", solved, D::Node, 3}, {"cg_iterations", cg_name, D::Scalar, 1}});
    if (line_search) {  // the solve's step scaled back where the contact would overshoot (ops/line_search.h)
      const int full = g.find_tensor(solved);
      g.add_op("line_search",
               {G("guess", guess), G("u_full", full), G("rotation", rotation), G("lambda", lambda), G("mu", mu),
                G("mass", t.mass), G("fixed", t.fixed), G("damping", step_damping),
                P("ground_planes", t.ground_planes), P("dt", t.dt), P("theta", t.theta),
                P("mass_damping", t.mass_damping), P("stiffness_damping", t.stiffness_damping)},
               {{"sums", name("line_search_sums"), D::Scalar, ops::kLineSearchSums}});
      g.add_op("line_search_step",
               {P("sums", g.find_tensor(name("line_search_sums"))), P("dt", t.dt), P("guess", guess),
                P("u_full", full)},
               {{"u", u_name, D::Node, 3}});
    }
    iterate = g.find_tensor(u_name);
  }
  t.u = g.find_tensor("u");
  t.cg_iterations = g.find_tensor("cg_iterations");
  g.add_op("velocity_update",
           {P("u", t.u), P("u_prev", t.u_prev), P("v_prev", t.v_prev), P("dt", t.dt), P("theta", t.theta)},
           {{"v", "v", D::Node, 3}});
  t.v = g.find_tensor("v");
  if (extension) {
    t.band_guess = g.add_state("band_guess", D::Band, 3);
    t.extension_op = int(g.ops().size());
    g.add_op("extension_solve", {G("u", t.u), OpArg{"band_guess", t.band_guess, A::Opaque}},
             {{"band_u", "band_u", D::Band, 3}});
    t.band_u = g.find_tensor("band_u");
  }
  g.validate();
  return t;
}

}  // namespace ssc
