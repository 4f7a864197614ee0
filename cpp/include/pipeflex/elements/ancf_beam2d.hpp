// Planar ANCF beam element (seed 002, Berzeri & Shabana) with two elastic force models.
//
// Coordinates e = [r_A (2), r_A' (2), r_B (2), r_B' (2)] [m, -]: nodal positions and
// slopes, cubic Hermite interpolation r(xi) = S(xi) e, xi = x/l. Residual
//     r(e, e_ddot) = M e_ddot + Q(e) - f_g,
// constant mass matrix M = rho A l int S^T S dxi (A-1; plus a tip mass at B, A-2) and
// gravity f_g = rho A l int S^T g dxi. Elastic forces Q:
//  * Model A (continuum mechanics, seed's Model A = Model III of its ref. [2]):
//      Q = (eps_A K_A + eps_M K_M + eps_B K_B + K_t) e,
//    K_X = EA int N_X S_x^T S_x dx (N_A = 1 - 4xi + 3xi^2, N_M = 6xi - 6xi^2,
//    N_B = -2xi + 3xi^2; A-6..A-8), K_t = EI int S_xx^T S_xx dx,
//    eps_A = |r_A'| - 1, eps_M = |r_B - r_A| / l - 1, eps_B = |r_B'| - 1.
//  * Model 0 (local element frame, linear strain; seed ref. [16]): the frame's x axis
//    follows the chord r_B - r_A; in it the local displacement u = e_l - e_l0 gives
//      U = 1/2 EA int (u_x')^2 dx + 1/2 EI int (u_y'')^2 dx,  Q = dU/de (exact gradient,
//    including the frame's rotation). No axial-bending coupling inside an element.
#pragma once

namespace pipeflex {

enum class AncfElastic : int { model_0 = 0, model_a = 1 };

struct AncfElementData {
    double l = 1.0;          // l [m] element length
    double EA = 0.0;         // E A [N] axial stiffness
    double EI = 0.0;         // E I [N m^2] bending stiffness
    double mass = 0.0;       // rho A [kg/m] mass per length
    double tip_mass = 0.0;   // m_t [kg] concentrated at node B (kernel use; models use nodal masses)
    AncfElastic elastic = AncfElastic::model_a;
    // Kelvin-Voigt damping: retardation times eta [s] of the axial and bending strains
    // (see ancf_tangent); c_ext [N s/m^2] external viscous damping per unit length. Zero:
    // skipped (the undamped results bit for bit).
    double eta_axial = 0.0, eta_bending = 0.0, c_ext = 0.0;
    // k_found [N/m^2]: elastic (Winkler) foundation per unit length, force -k_found (r - r0),
    // consistent: k_found l int S^T S dxi (e - e0), with e0 the reference coordinates [m, -]
    // (set by AncfElement::finalize). Zero: skipped.
    double k_found = 0.0;
    double e0[8] = {};
    bool damped() const { return eta_axial != 0.0 || eta_bending != 0.0 || c_ext != 0.0; }
};

// A frame turning about z through `center` at rate `rate` [rad/s] with angular
// acceleration `acceleration` [rad/s^2], in which the coordinates are measured. Its
// fictitious forces add M (2 rate S e_dot + (rate^2 S^2 + acceleration S)(e - c)) to the
// residual, S = [[0, -1], [1, 0]] on every 2-vector, c = [center, 0, center, 0].
struct AncfFrame {
    double rate = 0.0, acceleration = 0.0;
    double center[2] = {0.0, 0.0};
};

// Damping forces Q_d(e, e_dot) (added to the residual), linear in e_dot:
//  * Model A: eta_axial sum_X eps_dot_X K_X e + eta_bending K_t e_dot (the elastic forces
//    with the strains eps_X replaced by eta eps_dot_X, the bending by its rate);
//  * Model 0: dR/de_dot of R = 1/2 int (eta_axial EA (u_x'_t)^2 + eta_bending EI (u_y''_t)^2) dx,
//    u_t the rate of the local displacement (a rigid motion has u_t = 0);
//  * both: c_ext l int S^T S dxi e_dot (the consistent viscous force).
// The foundation K_f (e - e0), K_f = k_found l int S^T S dxi, adds to Q and K.
// Residual (8) and weighted tangent wK dr/de + wC dr/de_dot + wM M (row-major 8x8).
// gravity: g [m/s^2] (2), may be null; frame may be null (inertial coordinates).
// r or J may be null.
void ancf_tangent(const AncfElementData& d, const double* e, const double* v, const double* a,
                  const double* gravity, const AncfFrame* frame, double wK, double wC, double wM,
                  double* r, double* J);

// Geometric (prestress) stiffness of Model A at e for the strains linearised about e in
// the direction de: sum_X (d eps_X/de . de) K_X (row-major 8x8).
void ancf_geometric_stiffness(const AncfElementData& d, const double* e, const double* de, double* G);

// Elastic energy [J] (Model A: 1/2 EA int eps^2 dx with eps interpolated from eps_A,
// eps_M, eps_B, plus bending; Model 0: U above; both plus the foundation's
// 1/2 (e - e0)^T K_f (e - e0)) and kinetic energy 1/2 v^T M v [J].
// Power v . Q_d [W] (>= 0) of the damping forces Q_d at e, e_dot = v (Kelvin-Voigt
// eta_axial, eta_bending and viscous c_ext; see ancf_tangent); 0 without damping.
double ancf_damping_power(const AncfElementData& d, const double* e, const double* v);

void ancf_energies(const AncfElementData& d, const double* e, const double* v, double* kinetic, double* elastic);

// The constant matrices of the appendix (row-major 8x8): which = 0: K_A, 1: K_M, 2: K_B,
// 3: K_t, 4: M (with the tip mass).
void ancf_model_a_matrix(const AncfElementData& d, int which, double* out);

}  // namespace pipeflex
