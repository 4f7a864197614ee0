// Two-node 3D pipe/beam element with internal mass flow (seed 000, Meijaard & Hakvoort).
//
// Element coordinates q = [x^p, phi^p, x^q, phi^q] (12): nodal positions x [m] and
// spatial rotation vectors phi [rad] relative to the nodes' reference rotations.
// The element residual is
//     r(q, q_dot, q_ddot) = M(q) q_ddot + f_in(q, q_dot) + f_fluid(q, q_dot)
//                           + D(q)^T (sigma(q) + sigma_d(q, q_dot)) + f_c(q, q_dot) - f_gravity(q)
// so the equations of motion are sum_e r_e = external nodal loads. Inertia: Hermite
// interpolation of the centre line (eqs. 9-14) with the cross-section rotary inertia
// lumped at the nodes; fluid (eqs. 15-20): entrainment, relative (mdot_dot), Coriolis
// and centripetal terms in their unsplit form, which equals eqs. 19-20 plus their
// split-off end terms (so a kink automatically receives the forces of eqs. 21-22 and a
// free outlet none). Elastic: generalised strains eqs. 1-2, constitutive eqs. 6-7.
// Damping (PipeElementData::eta_*, c_ext): Kelvin-Voigt stresses sigma_d = C eta eps_dot
// of the generalised strains' rate and the external viscous force f_c of the centre line.
// Foundation (k_found): the elastic counterpart of c_ext, k_found l0 int N^T N dxi (a - a0)
// on the Hermite vectors a of the centre line, part of the elastic forces and energy.
#pragma once

#include "pipeflex/core/dual.hpp"
#include "pipeflex/core/rotation.hpp"
#include "pipeflex/core/small_matrix.hpp"

#include <array>

namespace pipeflex {

struct PipeElementData {
    double l0 = 1.0;              // l0 [m] reference (arc) length
    double EA = 0.0;              // E A_p [N] axial stiffness
    double GJ = 0.0;              // k_x G I_p [N m^2] torsional stiffness
    double EIy = 0.0;             // E I_y [N m^2] bending stiffness about local y
    double EIz = 0.0;             // E I_z [N m^2] bending stiffness about local z
    double Phi_y = 0.0;           // Phi_y [-] shear flexibility factor of eq. 7 (0: rigid in shear)
    double Phi_z = 0.0;           // Phi_z [-]
    std::array<double, 6> strain0{};  // eps^0 [m] stress-free generalised strains
    Mat3<double> offset_p{};      // end triad at p in the frame of node p
    Mat3<double> offset_q{};      // end triad at q in the frame of node q
    double pipe_mass = 0.0;       // rho_p A_p [kg/m]
    double fluid_mass = 0.0;      // rho_f A_f [kg/m]
    double kv = 1.0;              // k_v [-] momentum-flux correction factor (eq. 18)
    std::array<double, 3> rotary_inertia{};  // [kg m] mass moments of inertia per length
                                             // about local x, y, z (lumped at the nodes)
    double flow_factor = 1.0;     // [-] element mass flow = flow_factor * model mass flow
    // End terms of eqs. 19-20 at p and q (true: unsplit form). Dropping one gives the
    // split form there: e.g. an inlet fed from a still reservoir, where suction, not the
    // pipe, accelerates the fluid (the additional force of seed 000 cancels the term).
    bool end_terms_p = true;
    bool end_terms_q = true;
    // Kelvin-Voigt internal damping: sigma = C (eps - eps^0 + eta eps_dot) with the
    // retardation times eta [s] of the axial, torsional and bending strains (eps_dot the
    // rate of the objective generalised strains: no damping of a rigid motion). Zero: the
    // damping is skipped (no cost, the undamped results bit for bit).
    double eta_axial = 0.0, eta_torsion = 0.0, eta_bending = 0.0;
    // c_ext [N s/m^2]: external viscous damping per unit length, force -c_ext times the
    // centre line's velocity (Hermite-interpolated like the inertia).
    double c_ext = 0.0;
    // k_found [N/m^2]: elastic (Winkler) foundation per unit length, force -k_found times the
    // centre line's displacement r - r0 (Hermite-interpolated like the inertia). found0 [m]:
    // the reference centre line's Hermite vectors a0 = [X^p, l0 e0^p_x, X^q, l0 e0^q_x] (set by
    // PipeElement::finalize from the reference positions and offsets). Zero k_found: skipped.
    double k_found = 0.0;
    std::array<Vec3<double>, 4> found0{};
    bool kelvin_voigt() const { return eta_axial != 0.0 || eta_torsion != 0.0 || eta_bending != 0.0; }
};

// Time-dependent loading shared by all elements of a model.
struct LoadState {
    double mass_flow = 0.0;       // mdot [kg/s]
    double mass_flow_rate = 0.0;  // d(mdot)/dt [kg/s^2]
    std::array<double, 3> gravity{};  // g [m/s^2]
    double gravity_factor = 1.0;  // [-] multiplier (load stepping)
    double time = 0.0;  // t [s] of the nodal loads' time functions and load functions (statics: 0)
    // Co-rotating hub frame (ANCF models; see HubDrive): rate [rad/s], its rate [rad/s^2]
    // and the axis point [m]; the frame turns about global z.
    double frame_rate = 0.0, frame_acceleration = 0.0;
    std::array<double, 2> frame_center{};
};

// Reference rotations of the element's two nodes (row-major 3x3 each).
struct NodeFrames {
    Mat3<double> p, q;
};

// Element residual on scalar type S; acc is the acceleration q_ddot (12).
template <class S>
void pipe_residual(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                   const S* q, const S* v, const double* acc, S* r);
// The same with the nodes' rotation kinematics given (node_motion of q, v, acc at each
// node): the assembly evaluates them once per node for all the node's elements.
template <class S>
void pipe_residual(const PipeElementData& e, const NodeFrames& ref, const LoadState& load, const S* q, const S* v,
                   const double* acc, const NodeMotion<S>& np, const NodeMotion<S>& nq, S* r);

// Residual (r, 12) and the weighted tangent J = wK dr/dq + wC dr/dq_dot + wM M
// (row-major 12x12), derived by hand. Either output may be null.
void pipe_tangent(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                  const double* q, const double* v, const double* acc, double wK, double wC,
                  double wM, double* r, double* J);

// The tangents for nw weight sets at once, J[k] for weights[3k..3k+2] = (wK, wC, wM):
// the derivatives are computed once and only their weighted sums nw times (K, C and M
// of a linearisation for the cost of about one tangent). r may be null.
// sigma_geometric (6, may be null): generalised stresses for the geometric part of dr/dq
// (sum_i sigma_i d^2 eps_i/dq^2) in place of the state's own; the residual is unchanged.
// The mixed Newton of the statics passes pipe_predicted_stresses here.
void pipe_tangents(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                   const double* q, const double* v, const double* acc, int nw, const double* weights,
                   double* r, double* const* J, const double* sigma_geometric = nullptr);

// The generalised stresses (6) [N, N m] of the strains linearised at q and extrapolated
// along the increment dq (12): sigma(eps(q) + d eps/dq dq - eps^0). The mixed Newton
// (the stresses an independent field, eliminated per element: Magisano, Leonetti & Garcea
// 2017, "MIP Newton") takes them as the next tangent's geometric stresses: a large first
// increment stretches the chords by O(theta^2) and the state's axial force, EA times that,
// would otherwise stiffen the next tangent against the bending it has to correct.
void pipe_predicted_stresses(const PipeElementData& e, const NodeFrames& ref, const double* q, const double* dq,
                             double* sigma);

// The same by forward AD of pipe_residual (12 directions): the reference for tests.
void pipe_tangent_ad(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                     const double* q, const double* v, const double* acc, double wK, double wC,
                     double wM, double* r, double* J);

// Flow-dependent part of the residual (12, coordinates of r): the terms with mdot, its
// rate and P = kv mdot^2 / fluid mass, end terms included; r(flow) - r(no flow).
void pipe_fluid_forces(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                       const double* q, const double* v, double* f);
// Power -v . f [W] the fluid forces deliver to the pipe, f those of pipe_fluid_forces (not
// formed: the power integrated at every step of a transient).
double pipe_fluid_power(const PipeElementData& e, const NodeFrames& ref, const LoadState& load, const double* q,
                        const double* v);
// The same with the nodes' rotation kinematics given (node_motion at each node; its
// acceleration is not used): a transient's work evaluates them once per node.
double pipe_fluid_power(const PipeElementData& e, const NodeFrames& ref, const LoadState& load, const double* q,
                        const double* v, const NodeMotion<double>& np, const NodeMotion<double>& nq);

// Power v . f_d [W] (>= 0) of the damping part f_d of the residual at q, v: the
// Kelvin-Voigt forces (eta_axial, eta_torsion, eta_bending) and the external viscous
// forces (c_ext); 0 without damping.
double pipe_damping_power(const PipeElementData& e, const NodeFrames& ref, const double* q, const double* v);

// Mass matrix M(q) (row-major 12x12).
void pipe_mass_matrix(const PipeElementData& e, const NodeFrames& ref, const double* q,
                      double* M);

// Generalised strains minus their stress-free values, eps - eps^0 (6) [m].
void pipe_strains(const PipeElementData& e, const NodeFrames& ref, const double* q,
                  double* strain);

// Kinetic energy [J] (pipe and fluid carried along, rotary inertia) and elastic energy [J]
// (strains and the foundation's 1/2 k_found int (r - r0)^2 ds).
void pipe_energies(const PipeElementData& e, const NodeFrames& ref, const double* q,
                   const double* v, double* kinetic, double* elastic);

}  // namespace pipeflex
