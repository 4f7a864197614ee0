#include "pipeflex/solvers/rotating_systems.hpp"

#include <limits>
#include <stdexcept>

namespace pipeflex {

namespace {

Mat3d skew3(const Vec3d& a) {
    Mat3d S;
    S << 0.0, -a[2], a[1], a[2], 0.0, -a[0], -a[1], a[0], 0.0;
    return S;
}

// the products B(col, :) of the frame-position columns of X (the triplets of C or M,
// coordinate block only) with a 3 x 3 block B per body, weighted by w, appended to J
void add_frame_products(const Triplets& X, const std::vector<int>& frame, int n, const Mat3d& B, double w,
                        Triplets& J) {
    for (std::size_t k = 0; k < X.values.size(); ++k) {
        const int i = X.rows[k], j = X.cols[k];
        if (i >= n || j >= n || frame[j] < 0) continue;
        const int o = frame[j], row = j - o;
        for (int c = 0; c < 3; ++c) J.add(i, o + c, w * X.values[k] * B(row, c));
    }
}

}  // namespace

RigidRotationBodies::RigidRotationBodies(MultibodyEquations& mb, const MultibodySystemCore& sys, const Vec3d& point,
                                         const Vec3d& axis)
    : mb_(mb), sys_(sys), point_(point), axis_(axis), S_(skew3(axis)), S2_(S_ * S_),
      frame_(sys.n_coordinates(), -1), zero_(Eigen::VectorXd::Zero(sys.n_coordinates())) {
    for (int j = 0; j < sys.n_bodies(); ++j)
        for (int c = 0; c < 3; ++c) frame_[sys.offset(j) + c] = sys.offset(j);
}

void RigidRotationBodies::rigid_rates() {
    MbState& s = mb_.mutable_state();
    s.v.setZero(sys_.n_coordinates());
    s.a.setZero(sys_.n_coordinates());
    for (int j = 0; j < sys_.n_bodies(); ++j) {
        const int o = sys_.offset(j);
        const Vec3d w = omega_ * axis_.cross(s.r[j] - point_);
        s.v.segment<3>(o) = w;
        s.v.segment<3>(o + 3) = omega_ * axis_;
        s.a.segment<3>(o) = omega_ * axis_.cross(w);
    }
}

void RigidRotationBodies::set(const Eigen::VectorXd& z, const Eigen::VectorXd&, const Eigen::VectorXd&,
                              const Eigen::VectorXd& lambda, double t) {
    mb_.set(z, zero_, zero_, lambda, t);
    rigid_rates();
}

void RigidRotationBodies::evaluate(double wK, double, double, Eigen::VectorXd& residual, Triplets* tangent) {
    if (tangent == nullptr) {
        mb_.evaluate(1.0, 0.0, 0.0, residual, nullptr);
        return;
    }
    // dF/dv and dF/da (the joints' blocks come along: dropped), then K with the joints'
    mb_.evaluate(0.0, 1.0, 0.0, scratch_, &C_);
    mb_.evaluate(0.0, 0.0, 1.0, scratch_, &M_);
    mb_.evaluate(wK, 0.0, 0.0, residual, tangent);
    const int n = sys_.n_coordinates();
    add_frame_products(C_, frame_, n, S_, wK * omega_, *tangent);
    add_frame_products(M_, frame_, n, S2_, wK * omega_ * omega_, *tangent);
}

namespace {

// omega balancing the moment about the hinge, u . R with u the rates at omega = 1, of the
// state set (secant iterations from 0 and 1 rad/s)
double rigid_guess(RotatingSystem& sys, const Eigen::VectorXd& lam) {
    Equations& eq = sys.equations();
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(eq.n_coordinates());
    Eigen::VectorXd u, r;
    const auto at = [&](double w) {
        sys.set_omega(w);
        eq.set(zero, zero, zero, lam, 0.0);
    };
    at(1.0);
    sys.balance_weights(u);
    const auto moment = [&](double w) {
        at(w);
        eq.evaluate(1.0, 0.0, 0.0, r, nullptr);
        return u.dot(r.head(u.size()));
    };
    double w0 = 0.0, w1 = 1.0, f0 = moment(w0), f1 = moment(w1);
    for (int k = 0; k < 50; ++k) {
        if (f1 == f0) break;
        const double w = w1 - f1 * (w1 - w0) / (f1 - f0);
        w0 = w1;
        f0 = f1;
        w1 = w;
        f1 = moment(w1);
        if (std::abs(w1 - w0) <= 1e-10 * std::max(1.0, std::abs(w1))) break;
    }
    return w1;
}

}  // namespace

SteadyRotationOutcome steady_rotation(RotatingSystem& sys, const Eigen::VectorXd& pin, double mdot,
                                      double omega_guess, const SteadyRotationOptions& opt, Eigen::VectorXd& lam) {
    Equations& eq = sys.equations();
    if (pin.size() != eq.n_coordinates() || lam.size() != eq.n_constraints())
        throw std::invalid_argument("steady_rotation: the pin or the multipliers do not fit the system");
    if (opt.max_iterations < 1) throw std::invalid_argument("steady_rotation: max_iterations must be positive");
    StaticNewtonOptions nopt;
    nopt.tol = opt.tol;
    nopt.max_iterations = opt.max_iterations;
    nopt.dense_below = opt.dense_below;
    sys.set_mass_flow(mdot);
    sys.set_omega(std::isnan(omega_guess) ? rigid_guess(sys, lam) : omega_guess);
    PinnedRateBorder border(sys, pin);
    nopt.border = &border;
    const StaticNewtonResult res = static_newton(eq, 0.0, lam, nopt);
    SteadyRotationOutcome out;
    out.iterations = res.iterations;
    out.residual = res.residual;
    out.omega = sys.omega();
    out.singular = res.singular;
    out.converged = res.converged;
    return out;
}

namespace {

// An element model about its own hinge (a node with fixed position and one free rotation).
class RotatingElements final : public RotatingSystem {
   public:
    RotatingElements(const Model& model, State& state, const LoadState& load, double length_scale, int hinge_node,
                     int hinge_dof, const Vec3<double>& axis)
        : eq_(model, state, load, length_scale, hinge_node, axis), hinge_dof_(hinge_dof) {}
    Equations& equations() override { return eq_; }
    double omega() const override { return eq_.omega(); }
    void set_omega(double w) override { eq_.set_omega(w); }
    void set_mass_flow(double mdot) override { eq_.set_mass_flow(mdot); }
    void rates(Eigen::VectorXd& v) override {
        const ElementEquations& el = eq_.element_equations();
        v = reduce(el.model, el.state.v);
    }
    void balance_weights(Eigen::VectorXd& u) override {
        u = Eigen::VectorXd::Zero(eq_.n_coordinates());
        u[hinge_dof_] = 1.0;
    }

   private:
    RigidRotationEquations eq_;
    int hinge_dof_;
};

class RotatingBodies final : public RotatingSystem {
   public:
    RotatingBodies(const MultibodySystemCore& sys, MbState& s, double mdot, const RotationHinge& h)
        : target_(s), flow_(TimeTable::constant(mdot)), mb_(sys, s, flow_), eq_(mb_, sys, h.point, h.axis) {}
    Equations& equations() override { return eq_; }
    double omega() const override { return eq_.omega(); }
    void set_omega(double w) override { eq_.set_omega(w); }
    void set_mass_flow(double mdot) override { flow_ = TimeTable::constant(mdot); }
    void rates(Eigen::VectorXd& v) override { v = mb_.state().v; }
    void finish(const Eigen::VectorXd& lam) override {
        target_ = mb_.state();
        target_.lam = lam;
    }

   private:
    MbState& target_;
    TimeTable flow_;
    MultibodyEquations mb_;
    RigidRotationBodies eq_;
};

}  // namespace

std::unique_ptr<RotatingSystem> rotating_elements(const Model& model, State& state, const LoadState& load,
                                                  double length_scale, const RotationHinge& hinge,
                                                  Eigen::VectorXd& pin) {
    if (hinge.node < 0 || hinge.node >= model.n_nodes() || hinge.element_dof < 0 || hinge.element_dof >= model.n_dofs)
        throw std::invalid_argument("steady_rotation: the hinge node or coordinate is out of range");
    pin = Eigen::VectorXd::Zero(model.n_dofs);
    pin[hinge.element_dof] = 1.0;
    return std::make_unique<RotatingElements>(model, state, load, length_scale, hinge.node, hinge.element_dof,
                                              Vec3<double>{{hinge.axis[0], hinge.axis[1], hinge.axis[2]}});
}

std::unique_ptr<RotatingSystem> rotating_bodies(const MultibodySystemCore& sys, MbState& s, double mdot,
                                                const RotationHinge& hinge, Eigen::VectorXd& pin,
                                                Eigen::VectorXd& lam) {
    sys.check_state(s);
    if (hinge.body < 0 || hinge.body >= sys.n_bodies())
        throw std::invalid_argument("steady_rotation: the hinged body " + std::to_string(hinge.body) +
                                    " is not a body of the system");
    pin = Eigen::VectorXd::Zero(sys.n_coordinates());
    pin.segment<3>(sys.offset(hinge.body) + 3) = hinge.axis;
    lam = s.lam;
    return std::make_unique<RotatingBodies>(sys, s, mdot, hinge);
}

}  // namespace pipeflex
