// The CPU's element apply four cells at a time: ops::corotated_apply instantiated on a pack of
// four doubles in SIMD lanes (GCC vector extensions; AVX2 where the CPU has it, chosen at run
// time, else SSE2 pairs). Each lane does the scalar code's operations in its order, so the
// corners are the scalar apply's (a zero-weight corner in a group with weighted ones adds
// zeros where the scalar code skips it). The Newmark solve's iterations spend most of their
// time here (docs/benchmarks.md). In float, eight cells at a time, for the opt-in solve whose
// element arithmetic is single precision (runtime/solvers.cpp, SSC_CPU_SINGLE_APPLY).
#pragma once

namespace ssc {

// corner[24 e + 3 c + k] = (R_e K_e R_e^T p)_c for cells [0, cell_count), as
// ops::stiffness_apply_cell does one cell.
void stiffness_apply_cells(int cell_count, double h, const double* rotation, const double* weights,
                           const double* lambda, const double* mu, const double* p, const int* cell_nodes,
                           double* corner);
// The same in single precision, eight cells at a time.
void stiffness_apply_cells(int cell_count, float h, const float* rotation, const float* weights, const float* lambda,
                           const float* mu, const float* p, const int* cell_nodes, float* corner);

}  // namespace ssc
