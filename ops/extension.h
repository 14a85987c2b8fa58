// The displacement extension: the band nodes around the active ones (where the surface may
// move to) take the harmonic extension of the active nodes' displacement, L x = sum of the
// active neighbours' u with L the band's graph Laplacian (degree minus band neighbours).
// The engine's Jacobi-PCG schedule "band_laplacian" solves it (runtime/solvers.cpp,
// codegen/solver_snippets.cpp); L is symmetric, so the adjoint solves L y = x_bar and adds
// y to the active neighbours' u cotangent.
#pragma once
#include "ops/part.h"

namespace ssc {
namespace ops {

#ifdef SSC_OP_SPECS
inline OpSpec extension_solve_spec() {
  OpSpec s;
  s.name = "extension_solve";
  s.domain = Domain::Band;
  s.solver = "band_laplacian";
  s.slots = {in("u", Access::Gather), constant_in("band_guess", Access::Opaque), out("band_u")};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
