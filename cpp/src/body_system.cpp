// Floating-frame bodies and joints as a System: its runs are MultibodyEquations on a copy
// of the system's state, copied back when a run finishes.
#include "pipeflex/multibody/multibody_equations.hpp"
#include "pipeflex/solvers/system.hpp"

namespace pipeflex {

void append_body_outputs(const MultibodySystemCore& sys, const MbState& s, const TimeTable& mass_flow, double t,
                         MbEvaluation& ev, Record& out, const std::string& prefix) {
    const long nb = sys.n_bodies(), n = sys.n_coordinates(), nc = sys.n_constraints();
    auto put = [&](const char* name, const std::vector<long>& shape, const double* p, long size) {
        auto& series = out(prefix + name, shape);
        series.data.insert(series.data.end(), p, p + size);
    };
    for (long j = 0; j < nb; ++j) {
        put("r", {nb, 3}, s.r[j].data(), 3);
        const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R = s.R[j];
        put("R", {nb, 3, 3}, R.data(), 9);
    }
    put("eta", {n}, s.eta.data(), n);
    put("v", {n}, s.v.data(), n);
    put("a", {n}, s.a.data(), n);
    put("lam", {nc}, s.lam.data(), nc);
    sys.evaluate(s, mass_flow.at(t), mass_flow.rate(t), 1.0, 1.0, 0.0, 0.0, 0.0, false, ev);
    const double drift = sys.velocity_drift(s, ev);
    put("drift", {}, &drift, 1);
}

namespace {

class BodyRun final : public Run {
   public:
    BodyRun(const MultibodySystemCore& sys, MbState& target, const Drive& drive, System::Mode mode)
        : sys_(sys), target_(target), drive_(drive), statics_(mode == System::Mode::statics),
          eq_(sys, target, drive_.mass_flow, &drive_.load_factor) {
        t0 = target.t;
        v = target.v;
        a = target.a;
        lam = target.lam;
        for (int j = 0; j < sys.n_bodies(); ++j) frame_rotations.push_back(sys.offset(j) + 3);
        frames_end = sys.n_coordinates();
    }
    Equations& equations() override { return eq_; }
    void rebase_frames() override {
        Eigen::VectorXd unused;  // the bodies' rates are spatial: re-basing keeps them
        eq_.rebase(unused, unused);
    }
    void record(double t, Record& out) override {
        append_body_outputs(sys_, eq_.state(), drive_.mass_flow, t, ev_, out);
    }
    void sense(const SensorSpec& s, double t, double* value, double* rate) override {
        if (s.part != SensorPart::bodies && s.kind != SensorKind::custom) Run::sense(s, t, value, rate);
        sense_bodies(sys_, eq_.state(), s, t, value, rate);
    }
    void finish() override {
        target_ = eq_.state();
        if (!statics_) return;
        target_.lam = lam;
        target_.v.setZero();
        target_.a.setZero();
    }

   private:
    const MultibodySystemCore& sys_;
    MbState& target_;
    Drive drive_;
    bool statics_;
    MultibodyEquations eq_;
    MbEvaluation ev_;
};

class BodySystem final : public System {
   public:
    BodySystem(const MultibodySystemCore& sys, const MbState& state) : sys_(sys), state_(state) {
        sys_.check_state(state_);
    }
    std::unique_ptr<Run> start(const Drive& drive, Mode mode) override {
        sys_.check_state(state_);
        return std::make_unique<BodyRun>(sys_, state_, drive, mode);
    }
    // A mechanism's free frame motions are penalised (StaticNewtonOptions::shift).
    void static_policy(StaticNewtonOptions& opt, bool mechanism) const override {
        if (mechanism) opt.shift = multibody_frame_shift(sys_);
    }
    double length_scale() const override { return sys_.length_scale(); }
    std::unique_ptr<RotatingSystem> rotating(const RotationHinge& hinge, double mdot, Eigen::VectorXd& pin,
                                             Eigen::VectorXd& lam) override {
        return rotating_bodies(sys_, state_, mdot, hinge, pin, lam);
    }
    int n_coordinates() const override { return sys_.n_coordinates(); }
    int n_constraints() const override { return sys_.n_constraints(); }
    Eigen::VectorXd length_coordinates() const override { return body_length_coordinates(sys_); }
    double record_size() const override {
        return 12.0 * sys_.n_bodies() + 3.0 * sys_.n_coordinates() + sys_.n_constraints() + 1.0;
    }
    MbState* body_state() override { return &state_; }
    const MultibodySystemCore* bodies() const override { return &sys_; }

   private:
    const MultibodySystemCore& sys_;
    MbState state_;
};

}  // namespace

Eigen::VectorXd body_length_coordinates(const MultibodySystemCore& bodies) {
    Eigen::VectorXd out = Eigen::VectorXd::Ones(bodies.n_coordinates());
    for (int j = 0; j < bodies.n_bodies(); ++j) out.segment<3>(bodies.offset(j) + 3).setZero();  // the frame's turn
    return out;
}

std::unique_ptr<System> body_system(const MultibodySystemCore& bodies, const MbState& state) {
    return std::make_unique<BodySystem>(bodies, state);
}

}  // namespace pipeflex
