// The engine's solver schedules: what runs an op whose spec names a solver instead of parts
// (graph/op_spec.h). "newmark_pcg": the theta-scheme's system (a_m M + a_k R K R^T + C) u =
// rhs with fixed nodes eliminated, by Jacobi-PCG; its adjoint solves the same (symmetric)
// system for the cotangent of u and hands the parameters -mu_adj^T (dA/dp) u.
// "band_laplacian": the displacement extension's band Laplacian. The GPU's schedules of the
// same names are codegen/solver_snippets.cpp.
#pragma once
#include <string>

#include "runtime/interpreter.h"

namespace ssc {

template <class Real>
struct SolverSchedule {
  void (*forward)(Interpreter<Real>& in, const OpNode& op, int b);
  void (*adjoint)(Interpreter<Real>& in, const OpNode& op, int b);
};

// Throws std::logic_error for an unknown name.
template <class Real>
const SolverSchedule<Real>& solver_schedule(const std::string& name);

}  // namespace ssc
