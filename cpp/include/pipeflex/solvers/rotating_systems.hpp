// Steady rotation of systems with floating-frame bodies (pipeflex.steady_rotation of a
// MultibodySystem or a CoupledSystem): the rigid rotation of rigid_rotation.hpp for the
// bodies' coordinates, and the driver (continuation in the mass flow, omega as the one
// static_newton's border, constraints in its bordered KKT matrix) for any system that
// can be set in rigid rotation.
//
// A body's coordinates are its frame position r, a spatial rotation increment and its
// modal amplitudes eta; its rates are [r_dot; spatial angular velocity; eta_dot]. In rigid
// rotation at rate omega about the unit axis a through the fixed point x_h:
//     r_dot = omega a x (r - x_h),              angular velocity omega a,  eta_dot = 0,
//     r_ddot = omega^2 a x (a x (r - x_h)),     angular acceleration 0,    eta_ddot = 0,
// so that dv/dq per unit omega is skew(a) on the frame position and zero elsewhere, and
// da/dq per unit omega^2 is skew(a)^2 there.
#pragma once

#include "pipeflex/multibody/multibody_equations.hpp"
#include "pipeflex/solvers/rigid_rotation.hpp"

#include <algorithm>
#include <memory>
#include <cmath>
#include <string>
#include <vector>

namespace pipeflex {

// The bodies' equations in rigid rotation at rate omega [rad/s] about `axis` (unit) through
// `point`: the rates are functions of the frames' positions and omega, set at each set;
// the tangent is K + omega C Av + omega^2 M Aa plus the joints' blocks (static only: wK).
class RigidRotationBodies final : public Equations {
   public:
    RigidRotationBodies(MultibodyEquations& mb, const MultibodySystemCore& sys, const Vec3d& point, const Vec3d& axis);

    double omega() const { return omega_; }
    void set_omega(double w) {
        omega_ = w;
        rigid_rates();
    }

    int n_coordinates() const override { return mb_.n_coordinates(); }
    int n_constraints() const override { return mb_.n_constraints(); }
    double length_scale() const override { return mb_.length_scale(); }
    void set(const Eigen::VectorXd& z, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
             const Eigen::VectorXd& lambda, double t) override;
    void evaluate(double wK, double wC, double wM, Eigen::VectorXd& residual, Triplets* tangent) override;
    int rebase(Eigen::VectorXd& v, Eigen::VectorXd& a) override { return mb_.rebase(v, a); }
    void set_static_load_factor(double f) override { mb_.set_static_load_factor(f); }
    double mass_flow(double t) const override { return mb_.mass_flow(t); }
    std::string singular_mass_hint() const override { return mb_.singular_mass_hint(); }

   private:
    void rigid_rates();  // the state's v and a of the rotation at omega
    MultibodyEquations& mb_;
    const MultibodySystemCore& sys_;
    Vec3d point_, axis_;
    Mat3d S_, S2_;  // skew(a), skew(a)^2
    double omega_ = 0.0;
    // per coordinate: the first coordinate of its body's frame position if it is one of
    // those three, else -1
    std::vector<int> frame_;
    Eigen::VectorXd zero_, scratch_;
    Triplets C_, M_;
};

// A system that can be set in rigid rotation at a rate (the driver's view).
class RotatingSystem {
   public:
    virtual ~RotatingSystem() = default;
    virtual Equations& equations() = 0;
    virtual double omega() const = 0;
    virtual void set_omega(double w) = 0;  // the rates of the state set follow
    virtual void set_mass_flow(double mdot) = 0;
    // the reduced rates (n) of the state set
    virtual void rates(Eigen::VectorXd& v) = 0;
    // The weights u (n) of the moment u . R whose zero is the starting rate's balance,
    // called with the state set at omega = 1: by default those rates (the moment about the
    // hinge of all the forces); an element model takes its hinge coordinate's row.
    virtual void balance_weights(Eigen::VectorXd& u) { rates(u); }
    // The end state (as set) and the multipliers lam into the system's own state.
    virtual void finish(const Eigen::VectorXd& lam) { (void)lam; }
};

// omega as static_newton's border, the hinge angle pinned: g = pin . (the accumulated
// increment), c = pin, d = 0 (pin: the hinge coordinate's unit vector, or the axis on the
// hinged body's rotation increment). The tangent is singular by construction (the
// rotation about the hinge is a zero mode): the whole bordered matrix is solved.
struct PinnedRateBorder final : StaticBorder {
    RotatingSystem& sys;
    const Eigen::VectorXd& pin;
    double increment = 0.0;  // of the hinge angle [rad]
    PinnedRateBorder(RotatingSystem& s, const Eigen::VectorXd& p) : sys(s), pin(p) {}
    double parameter() const override { return sys.omega(); }
    void set_parameter(double w) override { sys.set_omega(w); }
    // the residual is quadratic in omega: the central difference is exact
    double difference_step() const override { return 0.5 * std::max(std::abs(sys.omega()), 1.0); }
    double constraint(Eigen::VectorXd* c, double* d) const override {
        if (c != nullptr) {
            *c = pin;
            *d = 0.0;
        }
        return increment;
    }
    void accumulate(const Eigen::VectorXd& dz, double dw) override {
        increment += pin.dot(dz);
        sys.set_omega(sys.omega() + dw);
    }
    bool bordered_only() const override { return true; }
};

// Steady rotation of `sys` at the mass flow mdot [kg/s]: one static_newton with omega as
// its border, from omega_guess or (NaN) the rate balancing the moment about the hinge,
// rates(omega = 1) . R, of the starting shape (secant iterations); lam: the multipliers
// (updated). The continuation in the flow is the caller's (pipeflex.analysis.steady).
SteadyRotationOutcome steady_rotation(RotatingSystem& sys, const Eigen::VectorXd& pin, double mdot,
                                      double omega_guess, const SteadyRotationOptions& opt, Eigen::VectorXd& lam);

// The hinge of a system's rotation: the axis through a fixed point, and the pinned angle:
// the rotation of `body` (hinged to the ground) about the axis, or (body < 0) the element
// model's hinge coordinate element_dof.
struct RotationHinge {
    Vec3d point = Vec3d::Zero();  // x_h [m]
    Vec3d axis = Vec3d::UnitZ();  // unit a
    int body = -1;
    int element_dof = -1;
    int node = -1;  // an element model alone: its hinge node (fixed position; point unused)
};

// An element model in rigid rotation about its hinge (hinge.node: fixed position, its one
// reduced coordinate hinge.element_dof a rotation about hinge.axis) from `state` (updated
// in place), at load.mass_flow; pin (n) set to the hinge coordinate's unit vector.
std::unique_ptr<RotatingSystem> rotating_elements(const Model& model, State& state, const LoadState& load,
                                                  double length_scale, const RotationHinge& hinge,
                                                  Eigen::VectorXd& pin);
// Bodies in rigid rotation about body hinge.body's ground hinge from the state s (updated
// by finish()) at the mass flow mdot [kg/s]; pin (n) the axis on the hinged body's rotation
// increment, lam the state's multipliers.
std::unique_ptr<RotatingSystem> rotating_bodies(const MultibodySystemCore& sys, MbState& s, double mdot,
                                                const RotationHinge& hinge, Eigen::VectorXd& pin,
                                                Eigen::VectorXd& lam);

}  // namespace pipeflex
