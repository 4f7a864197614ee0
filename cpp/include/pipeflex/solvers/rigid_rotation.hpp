// Steady rotation about a hinge: the relative equilibrium of an element model spinning
// at an unknown rate omega about its hinge (pipeflex.steady_rotation), by the one
// static_newton with omega as its border.
//
// The motion is a rigid rotation at rate omega about the unit axis a through the hinge
// point x_h, carrying a fixed deformation: at phi = 0 (the frames re-based at every
// iterate) node i moves with
//     x_dot = omega a x (x - x_h),  x_ddot = omega^2 a x (a x (x - x_h)),
//     phi_dot = omega a,            phi_ddot = 0,
// so that the residual R(q, v(q, omega), a(q, omega)) is a static one in q and omega
// (quadratic in omega) with the tangent K + omega C Av + omega^2 M Aa, Av and Aa the
// rates' derivatives in q per unit omega and omega^2 (one 6 x 6 block per node: the
// products keep the tangent's sparsity). The hinge angle is arbitrary: its increment is
// pinned by the border equation, and omega's column takes its place.
#pragma once

#include "pipeflex/solvers/element_equations.hpp"

namespace pipeflex {

// The element model's statics in rigid rotation at rate omega [rad/s] about `axis` (unit)
// through the position of `hinge_node`. Only the static tangent (wK) is provided: the
// state's rates are functions of q and omega, not unknowns.
class RigidRotationEquations final : public Equations {
   public:
    RigidRotationEquations(const Model& model, State& state, const LoadState& load, double length_scale,
                           int hinge_node, const Vec3<double>& axis);
    // about the axis through a fixed point x_h [m] (a hinge outside the model: a body's)
    RigidRotationEquations(const Model& model, State& state, const LoadState& load, double length_scale,
                           const Vec3<double>& hinge_point, const Vec3<double>& axis);

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
    // The reduced residual at the state set with the rates of rate w (for the rigid guess).
    const Eigen::VectorXd& residual_at(double w);

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
    double omega_ = 0.0;
    std::shared_ptr<const TangentPattern> pattern_;
    std::vector<double> K_, C_, M_;
    // Av and Aa (reduced dv/dq / omega and da/dq / omega^2 at phi = 0) are block diagonal
    // (a node's coordinates), so column c of C Av sums the columns of C in c's block: per
    // column c, its block's columns block_[c]..block_end_[c] and the weights Av(j, c),
    // Aa(j, c) at av_[c]...; the tangent's pattern (rows_, cols_) and, per product term
    // in that order, its entry (target_; K's entries first, in the pattern's order).
    std::vector<int> block_, block_end_, weight_, rows_, cols_, target_;
    std::vector<double> av_, aa_, values_;
    Eigen::VectorXd r_;
    void rigid_rates();  // state.v, state.a of the rotation at omega (state.q set, phi = 0)
};

// omega as static_newton's border: the parameter is the rotation rate, the equation pins
// the hinge angle's increment (g = its accumulated increment, c = e_hinge, d = 0). The
// tangent is singular (the rotation about the hinge is a zero mode): the whole bordered
// matrix is solved.
struct RotationRateBorder final : StaticBorder {
    RigidRotationEquations& eq;
    int hinge_dof;
    double increment = 0.0;  // of the hinge angle [rad]
    RotationRateBorder(RigidRotationEquations& e, int dof) : eq(e), hinge_dof(dof) {}
    double parameter() const override { return eq.omega(); }
    void set_parameter(double w) override { eq.set_omega(w); }
    // the residual is quadratic in omega: the central difference is exact for any step,
    // and one of omega's size keeps its round-off at that of the residual
    double difference_step() const override { return 0.5 * std::max(std::abs(eq.omega()), 1.0); }
    double constraint(Eigen::VectorXd* c, double* d) const override;
    void accumulate(const Eigen::VectorXd& dz, double dw) override {
        increment += dz[hinge_dof];
        eq.set_omega(eq.omega() + dw);
    }
    bool bordered_only() const override { return true; }
};

struct SteadyRotationOptions {
    int continuation_steps = 4;  // mdot raised from mdot/steps to mdot
    double tol = 1e-12;          // static_newton's tol (correction / length_scale, omega's / max(1, |omega|))
    int max_iterations = 30;     // per continuation step
    int dense_below = -1;  // StaticNewtonOptions::dense_below
};
struct SteadyRotationOutcome {
    bool converged = false, singular = false;
    double omega = 0.0;     // [rad/s]
    int iterations = 0;     // Newton iterations over all steps
    double residual = 0.0;  // |R| at the end [N]
    int step = 0;           // the last continuation step (1-based): the failed one
    int step_iterations = 0;
    double mass_flow = 0.0;  // of that step [kg/s]
};

// Steady rotation of `model` under load.mass_flow about the hinge (a node with fixed
// position and the single reduced coordinate hinge_dof, a rotation about the unit axis)
// from `state` (updated: the last iterate, with the rotation's rates), by continuation in
// the mass flow: one static_newton per step, omega scaled with the flow between steps
// (k / (k - 1)), starting from omega_guess or (NaN) the rate that balances the hinge
// moment of the starting shape at the first step's flow (secant iterations).
SteadyRotationOutcome steady_rotation(const Model& model, State& state, const LoadState& load, int hinge_node,
                                      int hinge_dof, const Vec3<double>& axis, double omega_guess,
                                      double length_scale, const SteadyRotationOptions& opt);

}  // namespace pipeflex
