// The CPU's element apply several cells at a time: ops::corotated_apply instantiated on a pack
// of doubles in SIMD lanes (GCC vector extensions), eight cells where the CPU has AVX-512, else
// four (AVX2 where the CPU has it, else SSE2 pairs), chosen at run time. Each lane does the
// scalar code's operations in its order, so the corners are the scalar apply's (a zero-weight
// corner in a group with weighted ones adds zeros where the scalar code skips it). The Newmark
// solve's iterations spend most of their time here (docs/benchmarks.md). In float, eight cells
// at a time, for the opt-in solve whose element arithmetic is single precision
// (runtime/solvers.cpp, SSC_CPU_SINGLE_APPLY).
#pragma once

namespace ssc {

// The cells a pack of doubles holds on this CPU: 8 with AVX-512, else 4.
int cell_pack_width();

// corner[24 e + 3 c + k] = (R_e K_e R_e^T p)_c for cells [0, cell_count), as
// ops::stiffness_apply_cell does one cell; `pack` cells at a time (4, or 8 where
// cell_pack_width() is 8; 0: cell_pack_width()).
void stiffness_apply_cells(int cell_count, double h, const double* rotation, const double* weights,
                           const double* lambda, const double* mu, const double* p, const int* cell_nodes,
                           double* corner, int pack = 0);
// The same in single precision, eight cells at a time.
void stiffness_apply_cells(int cell_count, float h, const float* rotation, const float* weights, const float* lambda,
                           const float* mu, const float* p, const int* cell_nodes, float* corner);

}  // namespace ssc
