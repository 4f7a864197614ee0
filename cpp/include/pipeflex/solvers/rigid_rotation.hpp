// Rigid rotation of an element model: its statics in a frame turning at rate omega about
// an axis, by the one static_newton. Two analyses:
//  * steady rotation about a hinge (pipeflex.steady_rotation): omega unknown, the centre
//    the hinge (a node's or a body's), omega as static_newton's border (the driver of
//    every system's steady rotation: rotating_systems.hpp);
//  * the rotating state at a prescribed rate (pipeflex.rotating_state, seed 002): omega
//    given, the centre a point (the hub's), the tangent through the unconstrained model.
//
// The motion is a rigid rotation at rate omega about the unit axis a through the centre
// x_c, carrying a fixed deformation: at phi = 0 (the frames re-based at every iterate)
// node i moves with
//     x_dot = omega a x (x - x_c),  x_ddot = omega^2 a x (a x (x - x_c)),
//     phi_dot = omega a,            phi_ddot = 0          (frame nodes),
//     d_dot = omega a x d,          d_ddot = omega^2 a x (a x d)   (ANCF slopes d),
// so that the residual R(q, v(q, omega), a(q, omega)) is a static one in q and omega
// (quadratic in omega) with the tangent K + omega C Av + omega^2 M Aa, Av and Aa the
// rates' derivatives in q per unit omega and omega^2 (one 6 x 6 block per node: the
// products keep the tangent's sparsity).
//
// The supports hold in the rotating frame, but the rate operator need not keep a
// supported increment supported (an ANCF clamp leaves the slope's length free: a x d is
// not along d). The exact tangent is then E^T (K_f + omega C_f Av_f + omega^2 M_f Aa_f) E
// with the matrices of the unconstrained model (`free`: the same nodes and elements,
// bases T_f) at the same state and E = pinv(T_f) T (the model's increments in the
// unconstrained model's coordinates).
#pragma once

#include "pipeflex/solvers/element_equations.hpp"
#include "pipeflex/solvers/tangent_csc.hpp"

namespace pipeflex {

// The rates of the rigid rotation at rate omega [rad/s] about the unit axis through the
// point centre [m], at phi = 0 (the formulas above): state.v and state.a from state.q (a
// state of the model: check_state's).
void rigid_rotation_rates(const Model& model, State& state, const Vec3<double>& centre, const Vec3<double>& axis,
                          double omega);

// The rigid rotation's rate operators on the coordinates of `free` (the model's
// unconstrained variant: the same nodes and elements, bases T_f), block diagonal by node:
// T_rel = pinv(T_f) T (nf x n: the model's increments in free's coordinates), A =
// pinv(T_f) Av T_f and B = pinv(T_f) Aa T_f (nf x nf), Av and Aa the rates' derivatives in
// q per unit omega and omega^2 at phi = 0 (per node: S and S^2 for positions and ANCF
// slopes, S/2 and S^2/6 for rotation vectors, S = skew(axis)). Throws
// std::invalid_argument if free has other nodes or elements, a node's supported
// increments are not free's, or the rotation turns free's increments out of them.
struct RigidRotationOperators {
    CscMatrix T_rel, A, B;
};
RigidRotationOperators rigid_rotation_operators(const Model& model, const Model& free, const Vec3<double>& axis);

// The element model's statics in rigid rotation at rate omega [rad/s] about `axis` (unit)
// through the position of `hinge_node`. Only the static tangent (wK) is provided: the
// state's rates are functions of q and omega, not unknowns.
class RigidRotationEquations final : public Equations {
   public:
    RigidRotationEquations(const Model& model, State& state, const LoadState& load, double length_scale,
                           int hinge_node, const Vec3<double>& axis);
    // about the axis through a fixed point x_h [m] (a hinge outside the model: a body's; a
    // hub's centre), the tangent through `free` (the model's unconstrained variant) if not null
    RigidRotationEquations(const Model& model, State& state, const LoadState& load, double length_scale,
                           const Vec3<double>& hinge_point, const Vec3<double>& axis, const Model* free = nullptr);

    double omega() const { return omega_; }
    // the rate [rad/s]; the rates of the state set follow
    void set_omega(double w) {
        omega_ = w;
        rigid_rates();
    }
    // the mass flow [kg/s] of the residual (the continuation's step)
    void set_mass_flow(double mdot) { statics_.eq.static_mdot = mdot; }
    // the element equations (their model and state) the rotation's are built on
    ElementEquations& element_equations() { return statics_.eq; }

    int n_coordinates() const override { return statics_.eq.n; }
    double length_scale() const override { return statics_.eq.length_scale(); }
    void set(const Eigen::VectorXd& z, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
             const Eigen::VectorXd& lambda, double t) override;
    void evaluate(double wK, double wC, double wM, Eigen::VectorXd& residual, Triplets* tangent) override;
    int rebase(Eigen::VectorXd& v, Eigen::VectorXd& a) override { return statics_.eq.rebase(0.0, v, a); }
    // the mixed Newton of the element statics
    void predict_stresses(const Eigen::VectorXd* dz) override { statics_.eq.predict_stresses(dz); }
    double mass_flow(double) const override { return statics_.eq.static_mdot; }

   private:
    ElementStatics statics_;
    Eigen::Vector3d hinge_point_;
    Vec3<double> axis_;
    const Model& assembled_;  // whose K, C, M: the model or its unconstrained variant
    double omega_ = 0.0;
    std::shared_ptr<const TangentPattern> pattern_;  // assembled_'s
    std::vector<double> K_, C_, M_;
    // E, Av E and Aa E (Av, Aa: dv/dq / omega and da/dq / omega^2 at phi = 0, in
    // assembled_'s coordinates) are block diagonal (a node's coordinates), so column c of
    // the tangent sums the columns of K, C, M in c's block: per column c, its block's
    // columns block_[c]..block_end_[c] and the weights E(j, c), Av E(j, c), Aa E(j, c) at
    // ek_[weight_[c]]...; each row ra of assembled_ adds to the model's rows
    // row_map_[row_ptr_[ra]..row_ptr_[ra + 1]) with the weights row_weight_ (E^T); the
    // tangent's pattern (rows_, cols_) and, per product term in that order, its entry
    // (target_).
    std::vector<int> block_, block_end_, weight_, row_ptr_, row_map_, rows_, cols_, target_;
    std::vector<double> ek_, av_, aa_, row_weight_, values_;
    Eigen::VectorXd ra_;
    void rigid_rates();  // state.v, state.a of the rotation at omega (state.q set, phi = 0)
};

// The rotating state at the prescribed rate omega [rad/s] about the unit axis through the
// point centre [m] (seed 002's hub): one static_newton from `state` (updated: the last
// iterate, with the rotation's rates), the tangent through `free` (the model's
// unconstrained variant: the same nodes and elements). Converged as the static analyses
// (the correction below tol length scales, or stalled at round-off), the converged
// correction applied; a correction longer than `divergence` length scales is divergence.
struct RotatingStateOptions {
    double tol = 1e-10;
    int max_iterations = 30;
    double divergence = 0.5;
    int dense_below = -1;  // StaticNewtonOptions::dense_below
};
StaticNewtonResult rotating_state(const Model& model, const Model& free, State& state, const LoadState& load,
                                  const Vec3<double>& centre, const Vec3<double>& axis, double omega,
                                  double length_scale, const RotatingStateOptions& opt);

// One Newton solve at one mass flow: the continuation in the flow is the caller's
// (pipeflex.analysis.steady: one driver for every system, bisecting failed steps).
struct SteadyRotationOptions {
    double tol = 1e-12;       // static_newton's tol (correction / length_scale, omega's / max(1, |omega|))
    int max_iterations = 30;
    int dense_below = -1;  // StaticNewtonOptions::dense_below
};
struct SteadyRotationOutcome {
    bool converged = false, singular = false;
    double omega = 0.0;     // [rad/s]
    int iterations = 0;     // Newton iterations
    double residual = 0.0;  // |R| at the end [N]
};

}  // namespace pipeflex
