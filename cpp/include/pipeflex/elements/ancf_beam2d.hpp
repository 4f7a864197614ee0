// Planar ANCF beam element (seed 002, Berzeri & Shabana), elastic "Model A".
//
// Coordinates e = [r_A (2), r_A' (2), r_B (2), r_B' (2)] [m, -]: nodal positions and
// slopes, cubic Hermite interpolation r(xi) = S(xi) e, xi = x/l. Residual
//     r(e, e_dot, e_ddot) = M e_ddot + (eps_A K_A + eps_M K_M + eps_B K_B + K_t) e
// with the constant mass matrix M = m int S^T S dxi (A-1; plus a tip mass at B, A-2),
// K_X = EA int N_X S_x^T S_x dx (N_A = 1 - 4xi + 3xi^2, N_M = 6xi - 6xi^2,
// N_B = -2xi + 3xi^2; A-6..A-8), K_t = EI int S_xx^T S_xx dx, and the strains
// eps_A = |r_A'| - 1, eps_M = |r_B - r_A| / l - 1, eps_B = |r_B'| - 1.
// Not yet wired into the Model/assembler (issue 4): a kernel with its tangents.
#pragma once

namespace pipeflex {

struct AncfElementData {
    double l = 1.0;          // l [m] element length
    double EA = 0.0;         // E A [N] axial stiffness
    double EI = 0.0;         // E I [N m^2] bending stiffness
    double mass = 0.0;       // rho A [kg/m] mass per length
    double tip_mass = 0.0;   // m_t [kg] concentrated at node B
};

// Residual (8) and weighted tangent wK dr/de + wC dr/de_dot + wM M (row-major 8x8);
// J may be null.
void ancf_model_a_tangent(const AncfElementData& d, const double* e, const double* v, const double* a,
                          double wK, double wC, double wM, double* r, double* J);

// The constant matrices of the appendix (row-major 8x8): which = 0: K_A, 1: K_M, 2: K_B,
// 3: K_t, 4: M (with the tip mass).
void ancf_model_a_matrix(const AncfElementData& d, int which, double* out);

}  // namespace pipeflex
