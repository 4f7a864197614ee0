// Fluid-conveying pipe body in the floating frame of reference (seed 004, section 7).
//
// Element kernel: constant shape-function integrals of a straight two-node 3-D beam
// element (translation field N(s): linear axial, cubic Hermite bending), per unit
// mass per length, and its linear Euler-Bernoulli stiffness. Node DOF order
// [u_x, u_y, u_z, theta_x, theta_y, theta_z] in the body frame; theta_z = du_y/ds,
// theta_y = -du_z/ds.
//
// Body kernel: with B = [Psi0 Phi] (rigid modes of the straight reference and the
// reduction basis) the simplified equations of motion of eq. 70, per body,
//
//   R^ [ M_loc R^T a + Q_v(w, eta, eta_dot, sdot, sddot) - N_g R^T g ]
//       + [0; 0; K_eta (eta - eta0) + D_eta eta_dot] = Q_external (+ constraint forces),
//
// with global coordinates [r; pi; eta], global velocities v = [r_dot; omega; eta_dot],
// accelerations a = v_dot, R^ = diag(R, R, I), w = R^T omega (body components), and
//
//   Q_v = sum_k w_k [A_k w + 2 B_k eta_dot + 2 sdot (Gx_k + GPhi_k eta)]
//         + 2 sdot CPhi eta_dot + sdot^2 (Hx + HPhi eta) + sddot (Cx + CPhi eta) + Q_u,
//
// Q_u the moment rows' part of the Coriolis forces f = 2 mu_f sdot dv/ds on the lever arm
// u = N Phi eta (B's rows take s e_x): int u x f = 2 sdot [D(eta) w - (eta^T GPhi_k,eta eta_dot)_k]
// with D = Ubar_x I - e_x Ubar^T + mu_f/2 [|u|^2 I - u u^T]_start^end - q~/2 (Ubar = int u mu_f,
// q = int u x u' mu_f = -(eta^T GPhi_k,eta eta)_k, GPhi_k,eta the elastic rows). Then the
// Coriolis forces' power is mu_f sdot [|v|^2] over the body's ends, v the nodes' velocities
// the joints tie, so that it cancels across a rigid joint at every deformation (without Q_u
// a loaded, deformed chain of bodies gains energy from the flow: a spurious flutter).
// Likewise the centrifugal forces mu_f sdot^2 u'' add int u x u'' = [u x u']_start^end.
// The flow's rate sddot loads the pipe axially, N(s) = mu_f sddot (s - s0), which a linearly
// elastic body does not feel laterally: its geometric stiffness mu_f sddot (Gs1 - s0 Gs0)
// (eta - eta0) is added to the elastic rows and the load's moment on the lever arm u,
// sddot (Ua eta) x e_x, to the moment rows (FfrfBodyData; zero for a steady flow).
//
// where A_k = B^T S_k Psi_r0, B_k = B^T S_k Phi, Gx_k = B^T G_k xbar, GPhi_k = B^T G_k Phi,
// Cx = B^T C xbar, CPhi = B^T C Phi, Hx, HPhi likewise (S_k = int N^T n~_k N (mu_p + mu_f),
// G_k = int N^T n~_k N' mu_f, C = int N^T N' mu_f, H = int N^T N'' mu_f), all constant.
#pragma once

#include "pipeflex/core/rotation_eigen.hpp"

#include <Eigen/Dense>

#include <array>

namespace pipeflex {

using MatX = Eigen::MatrixXd;
using VecX = Eigen::VectorXd;
using Mat12d = Eigen::Matrix<double, 12, 12>;
using Mat3d = Eigen::Matrix3d;
using Vec3d = Eigen::Vector3d;

// Integrals over one straight element of length l [m], per unit mass per length
// (multiply by mu [kg/m]): N^T N, N^T N', N^T N'', N^T n~_k N, N^T n~_k N' (k = x, y, z),
// and int N^T ds (12 x 3).
struct BeamIntegrals {
    Mat12d NN, NdN, NddN;
    std::array<Mat12d, 3> NSN, NSdN;
    Eigen::Matrix<double, 12, 3> N;
};

void beam_integrals(double l, BeamIntegrals& out);

// The lateral slopes' integrals over one element of length l [m] (s from its start node):
// G0 = int (N_y'^T N_y' + N_z'^T N_z') ds [1/m] and G1 = int s (...) ds [-]: the geometric
// stiffness of an axial force N(s) = N0 + N1 s is N0 G0 + N1 G1 (a body's rate stiffness).
void beam_slope_integrals(double l, Mat12d& G0, Mat12d& G1);

// Linear stiffness [N/m, N, N m] of the element: EA [N], GJ [N m^2], EIy (bending in
// the x-z plane, u_z) and EIz (x-y plane, u_y) [N m^2].
void beam_stiffness(double l, double EA, double GJ, double EIy, double EIz, Mat12d& out);

// Reduced constants of one body (sizes: n = 6 + m, m = number of elastic coordinates).
struct FfrfBodyData {
    MatX M;                        // n x n local mass B^T (M_p + M_f) B [kg, kg m, kg m^2]
    MatX K;                        // m x m  Phi^T K_p Phi
    VecX eta0;                     // m      preimposed (stress-free) elastic coordinates
    std::array<MatX, 3> A, Bk, GPhi;  // n x 3, n x m, n x m
    std::array<VecX, 3> Gx;        // n
    MatX CPhi, HPhi;               // n x m
    VecX Cx, Hx;                   // n
    MatX Ng;                       // n x 3  B^T int N^T (mu_p + mu_f) ds
    MatX D;                        // m x m  damping of the elastic coordinates [N s/m ...]
                                   // (modal damping; empty: undamped, skipped)
    // The Coriolis forces' moment about the frame on the deformed lever arm u = N Phi eta
    // (ffrf_body_forces); all empty (0 columns): left out.
    MatX Ubar;                     // 3 x m  int N Phi mu_f ds [kg]
    MatX Us, Ue;                   // 3 x m  the translation rows of Phi at the start and end node
    MatX dUs, dUe;                 // 3 x m  du/ds per eta there
    double mu_f = 0.0;             // fluid mass per length [kg/m]
    // The geometric stiffness of the fluid acceleration's axial force N(s) = mu_f sddot (s - s0)
    // (tension > 0; s0 the FfrfBodyMotion's rate_force_zero): mu_f sddot (Gs1 - s0 Gs0) acts on
    // eta - eta0 (ffrf_body_forces). Both empty: left out.
    MatX Gs0;                      // m x m  Phi^T int (lateral slopes)^T (lateral slopes) ds Phi [1/m]
    MatX Gs1;                      // m x m  the same weighted by s [-]
    // With them: Ua (3 x m) = int N Phi mu_f ds [kg], so that the fluid acceleration's load
    // -mu_f sddot r' has its moment on the deformed lever arm u: int u x (mu_f sddot e_x) in
    // the moment rows (to first order in eta; the elastic rows' share is Gs's).
    MatX Ua;
};

// Throws std::invalid_argument naming the first member whose size does not fit
// n = M.rows() (>= 6) and m = n - 6 (the kernels index all of them without checks).
void check_ffrf_body(const FfrfBodyData& d);

// Motion of one body at an instant (global components).
struct FfrfBodyMotion {
    Mat3d R = Mat3d::Identity();   // frame rotation, body -> global
    Vec3d omega = Vec3d::Zero();   // angular velocity [rad/s]
    VecX a;                        // n accelerations [r_ddot; omega_dot; eta_ddot]
    VecX eta, eta_dot;             // m
    double sdot = 0.0, sddot = 0.0;  // fluid speed [m/s] and its rate [m/s^2]
    Vec3d gravity = Vec3d::Zero();   // [m/s^2]
    // s0 [m]: where the axial force of the fluid's acceleration vanishes, in the body's s
    // (the free outlet's s for a cantilever; set per body instance from the flow path)
    double rate_force_zero = 0.0;
};

// Scratch space of ffrf_body_forces for a body of n coordinates: sized once, so that
// the kernel does not allocate in a time loop.
struct FfrfBodyWork {
    VecX b, L, col;                               // n
    Eigen::Matrix<double, Eigen::Dynamic, 3> dQdw, Aw, dL;  // n x 3
    MatX X;                                       // n x n
    void resize(Eigen::Index n);
};

// Residual (inertia + elastic - gravity, n) and the tangent
//   wK dF/d[dr, dpi, deta] + wC dF/d[r_dot, omega, eta_dot] + wM dF/da   (n x n)
// into caller-owned buffers (the tangent only when `with_tangent`); `work` is resized
// if it does not fit. Throws std::invalid_argument on inconsistent sizes.
void ffrf_body_forces(const FfrfBodyData& d, const FfrfBodyMotion& s, double wK, double wC, double wM,
                      FfrfBodyWork& work, Eigen::Ref<VecX> residual, Eigen::Ref<MatX> tangent, bool with_tangent);

// Winkler foundation of a body (section k_found [N/m^2]): the force -k_found (r(s) - r_ref(s))
// per length on the centre line r(s) = r + R X(s), X = N (xbar + Phi eta), from its reference
// r_ref(s) = r_ref + R_ref X0(s), X0 = N (xbar + Phi eta0) (the body's placement in the
// assembly). Its energy V = k/2 int |r - r_ref|^2 ds gives, in body components with
// p = R^T (r - r_ref), Q = R^T R_ref, the generalised forces
//   frame:   R (kL p + Xi - Q X0),   R (Xi x p - ax(W Q^T)),
//   elastic: XPhi^T p + K eta + x - sum_jl Q_jl C_jl,
// Xi = k int X ds = X + XPhi eta, W = k int X X0^T ds = W0 + (C_jl . eta)_jl, ax(T)_i =
// eps_ijk T_jk; the constants (k folded in, with NN_jl = int N_j^T N_l ds):
struct FfrfFoundation {
    double kL = 0.0;            // k L [N/m]; 0: no foundation
    Vec3d X = Vec3d::Zero();    // k int xbar ds [N]
    Vec3d X0 = Vec3d::Zero();   // k int X0 ds [N]
    Mat3d W0 = Mat3d::Zero();   // k int xbar X0^T ds (through NN_jl) [N m]
    MatX XPhi;                  // 3 x m  k int N Phi ds
    MatX K;                     // m x m  k Phi^T NN Phi
    VecX x;                     // m      k Phi^T NN xbar
    MatX C;                     // m x 9  k Phi^T NN_jl (xbar + Phi eta0), column 3 j + l
};

// Throws std::invalid_argument naming the first member whose size does not fit m elastic
// coordinates, or a negative or non-finite kL.
void check_ffrf_foundation(const FfrfFoundation& f, Eigen::Index m);

// Adds the foundation's generalised forces (n = 6 + m) to `residual` and, with_tangent,
// wK times their derivative in [dr, dpi, deta] (spatial increments, R <- exp(dpi~) R) to
// `tangent`: frame position r, rotation R, reference placement r_ref, R_ref [m, -].
void ffrf_foundation_forces(const FfrfFoundation& f, const Vec3d& r, const Mat3d& R, const Vec3d& r_ref,
                            const Mat3d& R_ref, const Eigen::Ref<const VecX>& eta, double wK,
                            Eigen::Ref<VecX> residual, Eigen::Ref<MatX> tangent, bool with_tangent);

}  // namespace pipeflex
