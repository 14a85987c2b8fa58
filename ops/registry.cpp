// Every op ssc knows, one line each (graph/op_spec.h). An op's spec sits beside its math in
// its ops/ header, compiled here only (SSC_OP_SPECS).
#define SSC_OP_SPECS
#include "graph/part_loop.h"
#include "ops/air_drag.h"
#include "ops/contact.h"
#include "ops/contact_implicit.h"
#include "ops/corotation.h"
#include "ops/elasticity.h"
#include "ops/extension.h"
#include "ops/friction.h"
#include "ops/line_search.h"
#include "ops/newmark.h"
#include "ops/neo_hookean.h"
#include "ops/nodal.h"
#include "ops/stiffness_field.h"

namespace ssc {

const std::vector<OpSpec>& op_registry() {
  static const std::vector<OpSpec> registry = {
      ops::stiffness_field_spec(),
      ops::lame_spec(),
      ops::node_mass_spec(),
      ops::corotation_spec(),
      ops::corotation_force_spec(),
      ops::theta_elastic_force_spec(),
      ops::contact_force_spec(),
      ops::step_iterate_spec(),
      ops::contact_implicit_spec(),
      ops::line_search_spec(),
      ops::line_search_step_spec(),
      ops::friction_spec(),
      ops::air_drag_spec(),
      ops::neo_hookean_system_spec(),
      ops::neo_hookean_correction_spec(),
      ops::node_force_spec(),
      ops::stiffness_apply_spec(),
      ops::newmark_rhs_spec(),
      ops::newmark_solve_spec(),
      ops::velocity_update_spec(),
      ops::extension_solve_spec(),
  };
  return registry;
}

}  // namespace ssc
