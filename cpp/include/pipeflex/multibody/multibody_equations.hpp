// A system of floating-frame bodies and joints as a system of equations for the solvers.
#pragma once

#include "pipeflex/core/format.hpp"
#include "pipeflex/errors.hpp"
#include "pipeflex/multibody/multibody.hpp"
#include "pipeflex/solvers/equations.hpp"

#include <string>
#include <vector>

namespace pipeflex {

// A system of bodies as equations for the solvers: z moves the base state's frames
// (r = r0 + z_r, R = exp(z_pi~) R0) and modal coordinates; v and a are the state's
// (spatial angular velocities of the frames). The tangent is left-trivialised at the
// state (exact at z = 0, where every step of the integrator starts).
class MultibodyEquations final : public Equations {
   public:
    MultibodyEquations(const MultibodySystemCore& sys, const MbState& s, const TimeTable& flow)
        : sys_(sys), base_(s), cur_(s), flow_(flow), n_(sys.n_coordinates()), nc_(sys.n_constraints()) {
        // S couples only bodies that share a joint, and a joint's rows touch only its
        // bodies: the triplets cover these blocks (a fixed pattern, zeros included).
        const int nb = sys.n_bodies();
        const std::vector<MbJoint>& joints = sys.joints();
        auto offsets = [&](int b) { return sys.offset(b); };
        auto rows = [&](std::size_t k) { return sys.constraint_row(static_cast<int>(k)); };
        std::vector<char> coupled(static_cast<size_t>(nb) * nb, 0);
        for (int b = 0; b < nb; ++b) coupled[b * nb + b] = 1;
        for (const MbJoint& j : joints)
            if (j.body_b >= 0) coupled[j.body_a * nb + j.body_b] = coupled[j.body_b * nb + j.body_a] = 1;
        for (int a = 0; a < nb; ++a)
            for (int b = 0; b < nb; ++b)
                if (coupled[a * nb + b])
                    blocks_.push_back({offsets(a), offsets(a + 1) - offsets(a), offsets(b), offsets(b + 1) - offsets(b)});
        for (size_t k = 0; k < joints.size(); ++k)
            for (int body : {joints[k].body_a, joints[k].body_b})
                if (body >= 0)
                    joint_blocks_.push_back({rows(k), rows(k + 1) - rows(k), offsets(body), offsets(body + 1) - offsets(body)});
    }

    const MbState& state() const { return cur_; }
    MbState& mutable_state() { return cur_; }  // for differencing; restore what you change
    MbEvaluation& evaluation() { return ev_; }

    int n_coordinates() const override { return n_; }
    int n_constraints() const override { return nc_; }
    double length_scale() const override { return sys_.length_scale(); }

    void set(const Eigen::VectorXd& z, const Eigen::VectorXd& v, const Eigen::VectorXd& a, const Eigen::VectorXd& lam,
             double t) override {
        for (int j = 0; j < sys_.n_bodies(); ++j) {
            const int o = sys_.offset(j), m = sys_.offset(j + 1) - o - 6;
            cur_.r[j] = base_.r[j] + z.segment<3>(o);
            cur_.R[j] = rotation_exp(Vec3d(z.segment<3>(o + 3))) * base_.R[j];
            cur_.eta.segment(o + 6, m) = base_.eta.segment(o + 6, m) + z.segment(o + 6, m);
        }
        cur_.v = v;
        cur_.a = a;
        cur_.lam = lam;
        cur_.t = t;
    }

    void evaluate(double wK, double wC, double wM, Eigen::VectorXd& r, Triplets* J) override {
        sys_.evaluate(cur_, flow_.at(cur_.t), flow_.rate(cur_.t), 1.0, 1.0, wK, wC, wM, J != nullptr, ev_);
        r.resize(n_ + nc_);
        r.head(n_) = ev_.F;
        r.tail(nc_) = ev_.c;
        if (!J) return;
        J->clear();
        for (const Block& b : blocks_)
            for (int c = b.c0; c < b.c0 + b.nc; ++c)
                for (int i = b.r0; i < b.r0 + b.nr; ++i) push(*J, i, c, ev_.S(i, c));
        for (const Block& b : joint_blocks_)
            for (int c = b.c0; c < b.c0 + b.nc; ++c)
                for (int i = b.r0; i < b.r0 + b.nr; ++i) {
                    push(*J, n_ + i, c, ev_.J(i, c));
                    push(*J, c, n_ + i, ev_.J(i, c));
                }
    }

    int rebase(Eigen::VectorXd&, Eigen::VectorXd&) override {
        base_ = cur_;
        return 0;
    }

    void accept(double t, double) override {
        bool finite = cur_.eta.allFinite() && cur_.v.allFinite() && cur_.lam.allFinite();
        for (int j = 0; j < sys_.n_bodies(); ++j) finite = finite && cur_.r[j].allFinite() && cur_.R[j].allFinite();
        if (finite) return;
        ConvergenceError::Where where;
        where.time = t;
        where.mass_flow = mass_flow(t);
        throw ConvergenceError("the motion diverged at t = " + fmt(t) + " s: the state is not finite", where);
    }

    double mass_flow(double t) const override { return flow_.at(t); }
    RefreshPolicy refresh_policy() const override { return {kSlowRate, kLongStep}; }
    std::string singular_mass_hint() const override {
        return "the joints lock a motion twice or leave a body's mass matrix singular";
    }

   private:
    static constexpr double kSlowRate = 1.5;
    static constexpr int kLongStep = 5;
    struct Block {
        int r0, nr, c0, nc;
    };
    static void push(Triplets& J, int r, int c, double v) {
        J.rows.push_back(r);
        J.cols.push_back(c);
        J.values.push_back(v);
    }

    const MultibodySystemCore& sys_;
    MbState base_, cur_;
    const TimeTable& flow_;
    int n_, nc_;
    MbEvaluation ev_;
    std::vector<Block> blocks_, joint_blocks_;
};

}  // namespace pipeflex
