// Integration over a partially filled ("cut") hexahedral cell.
//
// A cell of size h carries 8 corner SDF values phi_c (corner c = bx + 2*by + 4*bz). Inside
// the cell the SDF is their trilinear interpolation and the body is {phi <= 0}. For each
// corner we need
//   volume[c]  = integral over the body part of the cell of N_c      (sum = cut volume)
//   surface[c] = integral over the zero level set in the cell of N_c  (sum = surface area)
// with N_c the trilinear shape functions. These are the partial-volume weights of the mass,
// stiffness and body-force terms and the boundary weights of the Nitsche terms.
//
// Method: full cells (all corners <= 0) and empty cells (all corners > 0; the trilinear field
// is bounded by its corner extremes) take the closed form. Cut cells are split into
// subdivisions^3 sub-cubes; full/empty sub-cubes again take the closed form, the others are
// split into the 6 tetrahedra of kCellTetrahedra with phi linear in each (exact trilinear
// values at the tetrahedron corners). Each tetrahedron is clipped by phi <= 0 (a tetrahedron
// or a prism of 3 tetrahedra) and N_c is integrated with a rule exact for cubics; the planar
// zero-level polygon (triangle or quad) is integrated with a triangle rule exact for cubics.
// The only error is the linearisation of phi: O((h/subdivisions)^2). A linear phi is exact.
//
// A level set lying exactly on a tetrahedron face (phi = 0 on the face, > 0 beyond it)
// is counted by the tetrahedron on the positive side, so a zero face between a full cell and
// an empty one is reported by the empty (all corners >= 0) cell, never twice.
#pragma once
#include <array>

namespace ssc {

struct CutCellIntegrals {
  std::array<double, 8> volume{};   // integral of N_c over the body part, m^3
  std::array<double, 8> surface{};  // integral of N_c over the zero level set, m^2
  double volume_total = 0;          // sum of volume
  double area_total = 0;            // sum of surface
};

// The 6 tetrahedra (Kuhn decomposition) of a unit cell, as cell corner indices. All share the
// diagonal corner 0 -> corner 7 and each is positively oriented (det(v1-v0, v2-v0, v3-v0) > 0).
// Every cell face is split along the diagonal from its lowest to its highest corner, so the
// decomposition is conforming across neighbouring cells of a regular grid.
inline constexpr std::array<std::array<int, 4>, 6> kCellTetrahedra = {{
    {0, 1, 3, 7},  // x, then y, then z
    {0, 5, 1, 7},  // x, z, y (odd permutation: middle vertices swapped)
    {0, 3, 2, 7},  // y, x, z (odd)
    {0, 2, 6, 7},  // y, z, x
    {0, 4, 5, 7},  // z, x, y
    {0, 6, 4, 7},  // z, y, x (odd)
}};

// Throws InputError for a non-finite phi, h <= 0 or subdivisions < 1.
CutCellIntegrals integrate_cut_cell(const std::array<double, 8>& phi, double h,
                                    int subdivisions = 4);

}  // namespace ssc
