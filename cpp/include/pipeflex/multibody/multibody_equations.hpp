// A system of floating-frame bodies and joints as a system of equations for the solvers.
#pragma once

#include "pipeflex/core/format.hpp"
#include "pipeflex/errors.hpp"
#include "pipeflex/multibody/multibody.hpp"
#include "pipeflex/solvers/equations.hpp"
#include "pipeflex/solvers/linear_matrices.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace pipeflex {

// A system of bodies as equations for the solvers: z moves the base state's frames
// (r = r0 + z_r, R = exp(z_pi~) R0) and modal coordinates; v and a are the state's
// (spatial angular velocities of the frames). The tangent is left-trivialised at the
// state (exact at z = 0, where every step of the integrator starts).
class MultibodyEquations final : public Equations {
   public:
    // loads: the load factor lambda(t) of a transient's loads (the Drive's; none: 1)
    MultibodyEquations(const MultibodySystemCore& sys, const MbState& s, const TimeTable& flow,
                       const TimeTable* loads = nullptr)
        : sys_(sys), base_(s), cur_(s), flow_(flow), loads_(loads), n_(sys.n_coordinates()),
          nc_(sys.n_constraints()), start_r_(s.r) {}

    const MbState& state() const { return cur_; }
    MbState& mutable_state() { return cur_; }  // rates set by a wrapper (RigidRotationBodies)
    MbEvaluation& evaluation() { return ev_; }

    int n_coordinates() const override { return n_; }
    int n_constraints() const override { return nc_; }
    double length_scale() const override { return sys_.length_scale(); }
    // a frame's rotation counts at the model size; its translation and the elastic
    // coordinates (modes scaled to a largest nodal entry of 1) as displacements
    void error_scales(Eigen::VectorXd& s) const override {
        s = Eigen::VectorXd::Ones(n_);
        for (int j = 0; j < sys_.n_bodies(); ++j) s.segment<3>(sys_.offset(j) + 3).setConstant(sys_.length_scale());
    }

    // the largest displacement of a frame's origin from its position at the run's start
    double motion_size() const override {
        double d2 = 0.0;
        for (std::size_t j = 0; j < cur_.r.size(); ++j) d2 = std::max(d2, (cur_.r[j] - start_r_[j]).squaredNorm());
        return std::sqrt(d2);
    }

    void set(const Eigen::VectorXd& z, const Eigen::VectorXd& v, const Eigen::VectorXd& a, const Eigen::VectorXd& lam,
             double t) override {
        for (int j = 0; j < sys_.n_bodies(); ++j) {
            const int o = sys_.offset(j), m = sys_.offset(j + 1) - o - 6;
            cur_.r[j] = base_.r[j] + z.segment<3>(o);
            cur_.R[j] = rotation_exp(Vec3d(z.segment<3>(o + 3))) * base_.R[j];
            cur_.eta.segment(o + 6, m) = base_.eta.segment(o + 6, m) + z.segment(o + 6, m);
        }
        z_ = z;
        cur_.v = v;
        cur_.a = a;
        cur_.lam = lam;
        cur_.t = t;
    }

    void evaluate(double wK, double wC, double wM, Eigen::VectorXd& r, Triplets* J) override {
        const bool fixed = !std::isnan(static_mdot_);
        // the loads (and hinge torques) follow lambda(t) as an element model's nodal loads; gravity does not
        const double loads = factor_ * (loads_ != nullptr ? loads_->at(cur_.t) : 1.0);
        sys_.evaluate(cur_, fixed ? static_mdot_ : flow_.at(cur_.t), fixed ? 0.0 : flow_.rate(cur_.t), loads, factor_,
                      wK, wC, wM, J != nullptr, ev_);
        r.resize(n_ + nc_);
        r.head(n_) = ev_.F;
        r.tail(nc_) = ev_.c;
        if (!J) return;
        J->clear();
        // S couples only bodies that share a joint, and a joint's rows touch only its bodies:
        // the triplets cover these blocks (a fixed pattern, zeros included)
        const auto& pairs = sys_.tangent_pairs();
        for (std::size_t k = 0; k < pairs.size(); ++k) {
            const MatX& B = ev_.S[k];
            const int r0 = sys_.offset(pairs[k].first), c0 = sys_.offset(pairs[k].second);
            for (int c = 0; c < B.cols(); ++c)
                for (int i = 0; i < B.rows(); ++i) J->add(r0 + i, c0 + c, B(i, c));
        }
        const std::vector<MbJoint>& joints = sys_.joints();
        for (std::size_t k = 0; k < joints.size(); ++k) {
            const MbJointWork& w = ev_.joint_work[k];
            const int r0 = n_ + sys_.constraint_row(static_cast<int>(k));
            push_block(*J, r0, sys_.offset(joints[k].body_a), w.Ja);
            if (joints[k].body_b >= 0) push_block(*J, r0, sys_.offset(joints[k].body_b), w.Jb);
        }
    }

    int rebase(Eigen::VectorXd&, Eigen::VectorXd&) override {
        base_ = cur_;
        z_.setZero();
        return 0;
    }
    // The frames' rotation coordinates (R = exp(z~) R0) move at zd = T(z)^-1 omega.
    void chart_rates(const Eigen::VectorXd& w, Eigen::VectorXd& zd) const override {
        zd = w;
        if (z_.size() != n_) return;  // nothing set yet: z = 0
        for (int j = 0; j < sys_.n_bodies(); ++j) {
            const int o = sys_.offset(j) + 3;
            const Vec3d phi = z_.segment<3>(o);
            if (phi.squaredNorm() > 0.0) zd.segment<3>(o) = rotation_jacobian(phi).partialPivLu().solve(Vec3d(w.segment<3>(o)));
        }
    }
    void rate_increments(const Eigen::VectorXd& dz, Eigen::VectorXd& w) const override {
        w = dz;
        if (z_.size() != n_) return;
        for (int j = 0; j < sys_.n_bodies(); ++j) {
            const int o = sys_.offset(j) + 3;
            const Vec3d phi = z_.segment<3>(o);
            if (phi.squaredNorm() > 0.0) w.segment<3>(o) = rotation_jacobian(phi) * Vec3d(dz.segment<3>(o));
        }
    }
    double chart_rotation() const override {
        double big = 0.0;
        if (z_.size() != n_) return big;
        for (int j = 0; j < sys_.n_bodies(); ++j) big = std::max(big, z_.segment<3>(sys_.offset(j) + 3).norm());
        return big;
    }

    void accept(double t, double h) override {
        bool finite = cur_.eta.allFinite() && cur_.v.allFinite() && cur_.lam.allFinite();
        double far = 0.0;
        int body = 0;
        for (int j = 0; j < sys_.n_bodies(); ++j) {
            finite = finite && cur_.r[j].allFinite() && cur_.R[j].allFinite();
            const double d = (cur_.r[j] - start_r_[j]).norm();
            if (d > far) far = d, body = j;
        }
        const double limit = kDivergenceLimit * sys_.length_scale();
        if (finite && far <= limit) return;
        ConvergenceError::Where where;
        where.time = t;
        where.mass_flow = mass_flow(t);
        throw ConvergenceError("the motion diverged at t = " + fmt(t) + " s (step " + fmt(h) + " s): " +
                                   (finite ? "body " + std::to_string(body) + " moved " + fmt(far) +
                                                 " m from where it started (limit " + fmt(limit) + " m)"
                                           : std::string("the state is not finite")),
                               where);
    }

    double mass_flow(double t) const override { return std::isnan(static_mdot_) ? flow_.at(t) : static_mdot_; }
    void set_static_load_factor(double f) override { factor_ = f; }
    void set_static_mass_flow(double mdot) override { static_mdot_ = mdot; }
    RefreshPolicy refresh_policy() const override { return {kSlowRate, kLongStep}; }
    std::string singular_mass_hint() const override {
        return "the joints lock a motion twice or leave a body's mass matrix singular";
    }

   private:
    // a frame farther than this many model sizes (length_scale) from its start: the motion diverged
    static constexpr double kDivergenceLimit = 1e3;
    static constexpr double kSlowRate = 1.5;
    static constexpr int kLongStep = 5;
    // A joint's block B at rows r0.. and body columns c0.., and its transpose.
    static void push_block(Triplets& J, int r0, int c0, const MatX& B) {
        for (int c = 0; c < B.cols(); ++c)
            for (int i = 0; i < B.rows(); ++i) {
                J.add(r0 + i, c0 + c, B(i, c));
                J.add(c0 + c, r0 + i, B(i, c));
            }
    }

    const MultibodySystemCore& sys_;
    MbState base_, cur_;
    Eigen::VectorXd z_;  // the chart coordinates set
    const TimeTable& flow_;
    const TimeTable* loads_;
    int n_, nc_;
    std::vector<Vec3d> start_r_;
    double factor_ = 1.0;  // loads and gravity (statics steps them)
    double static_mdot_ = std::numeric_limits<double>::quiet_NaN();  // [kg/s] if set, else the flow's
    MbEvaluation ev_;
};

// The penalty on a mechanism's free frame motions, relative to the stiffness block's
// largest magnitude (StaticNewtonOptions::shift): free motions much softer are left alone
// (the dense null-space step's pseudo-inverse cut at 1e-9), stiffer ones (a pendulum's
// gravity) converge at the rate 4 penalty / their stiffness. 1e-10 slowed a chain of
// spherical joints to a crawl (its spins' penalty met the bodies' torsion); relative to
// the bodies' softest stiffness instead, a ball-jointed pipe's weight walked it to hang.
constexpr double kMechanismShift = 1e-11;

// The frames' free motions (FreeMotions, S the frames' coordinates) at the state s (its
// multipliers; at rest) under the mass flow mdot [kg/s] and the full loads and gravity.
FreeMotions multibody_free_motions(const MultibodySystemCore& sys, const MbState& s, double mdot);
// The frames' weights of the mechanism penalty (StaticNewtonOptions::shift): kMechanismShift
// on every frame coordinate, zero on the elastic ones.
Eigen::VectorXd multibody_frame_shift(const MultibodySystemCore& sys);

}  // namespace pipeflex
