// The element model as a System: its runs are ElementEquations on the model's state.
#include "pipeflex/solvers/element_equations.hpp"
#include "pipeflex/solvers/system.hpp"

#include <algorithm>
#include <cmath>

namespace pipeflex {

void append_element_outputs(const TransientOutput& o, long N, Record& out, bool counters) {
    auto put = [&](const char* name, const std::vector<long>& shape, const std::vector<double>& v) {
        auto& s = out(name, shape);
        s.data.insert(s.data.end(), v.begin(), v.end());
    };
    put("x", {N, 3}, o.x);
    put("R", {N, 3, 3}, o.R);
    put("xd", {N, 3}, o.xd);
    put("omega", {N, 3}, o.w);
    put("kinetic", {}, o.kinetic);
    put("elastic", {}, o.elastic);
    put("gravity_potential", {}, o.gravity_potential);
    put("fluid_work", {}, o.fluid_work);
    put("load_work", {}, o.load_work);
    put("dissipated", {}, o.dissipated);
    if (counters)
        out.counters = {{"steps", o.steps},     {"newton_iterations", o.newton_iterations},
                        {"jacobians", o.jacobians}, {"rebases", o.rebases},
                        {"failed_steps", o.failed_steps}, {"convergence_failures", o.convergence_failures}};
}

void element_static_policy(StaticNewtonOptions& opt) {
    opt.apply_converged_correction = true;
    opt.divergence_from = 2;
}

Eigen::VectorXd element_length_coordinates(const Model& model) {
    const int N = model.n_nodes();
    Eigen::VectorXd position = Eigen::VectorXd::Zero(6 * N), turn = Eigen::VectorXd::Zero(6 * N);
    for (int i = 0; i < N; ++i) {
        position.segment<3>(6 * i).setOnes();
        turn.segment<3>(6 * i + 3).setOnes();
    }
    // a basis column with position entries and none of rotation (or slope) moves a position
    const Eigen::VectorXd p = reduce(model, position), r = reduce(model, turn);
    Eigen::VectorXd out(p.size());
    for (int j = 0; j < p.size(); ++j) out[j] = p[j] != 0.0 && r[j] == 0.0 ? 1.0 : 0.0;
    return out;
}

double model_length_scale(const Model& model) {
    double extent = 0.0;
    for (int k = 0; k < 3; ++k) {
        double lo = 0.0, hi = 0.0;
        for (int i = 0; i < model.n_nodes(); ++i) {
            const double x = model.positions[static_cast<std::size_t>(i)][k];
            lo = i == 0 ? x : std::min(lo, x);
            hi = i == 0 ? x : std::max(hi, x);
        }
        extent = std::max(extent, hi - lo);
    }
    return std::max(extent, kMinLengthScale);
}

void record_element(const ElementEquations& eq, double t, Record& out) {
    TransientOutput o;
    double fw = eq.fluid_work, lw = eq.load_work, dw = eq.dissipated;
    if (t < eq.last_power_t && eq.last_power_t > eq.previous_power_t) {  // inside the last step (IDA's outputs)
        const double s = (t - eq.previous_power_t) / (eq.last_power_t - eq.previous_power_t);
        fw = eq.previous_fluid_work + s * (fw - eq.previous_fluid_work);
        lw = eq.previous_load_work + s * (lw - eq.previous_load_work);
        if (eq.damped) dw = eq.previous_dissipated + s * (dw - eq.previous_dissipated);
    }
    eq.record(t, o, fw, lw, dw);
    append_element_outputs(o, eq.model.n_nodes(), out);
}

namespace {

class ElementRun final : public Run {
   public:
    ElementRun(const Model& model, State& state, const LoadState& load, const Drive& drive, System::Mode mode)
        : drive_(drive), functions_{drive_.mass_flow, drive_.load_factor},
          eq_(model, state, mode == System::Mode::statics ? unit_gravity(load) : load, functions_, drive_.options) {
        drive_.options.length_scale = model_length_scale(model);  // eq_ refers to drive_.options
        if (mode == System::Mode::statics) {
            // no hub motion, frames re-based past pi only (ElementEquations::statics)
            eq_.statics = true;
            eq_.rebase_angle = M_PI;
            eq_.set_static_mass_flow(drive_.mass_flow.at(0.0));
        } else if (mode == System::Mode::dynamics) {
            v = reduce(model, state.v);
            eq_.rebase(0.0, v, a);  // the chart of the state's frames: z = 0, v and a mapped
        } else if (!model.hub.nodes.empty()) {
            throw std::invalid_argument("flow map: a model with a hub drive is not autonomous");
        }
    }
    Equations& equations() override { return eq_; }
    void begin(double t) override { eq_.start_work(t); }
    void record(double t, Record& out) override { record_element(eq_, t, out); }
    void sense(const SensorSpec& s, double t, double* value, double* rate) override {
        sense_element(eq_, s, t, value, rate);
    }
    void finish() override {}  // the equations work on the system's state

   private:
    // statics: gravity, as the loads, times the static load factor
    static LoadState unit_gravity(const LoadState& load) {
        LoadState base = load;
        base.gravity_factor = 1.0;
        return base;
    }
    Drive drive_;
    TimeFunctions functions_;
    ElementEquations eq_;
};

class ElementSystem final : public System {
   public:
    ElementSystem(const Model& model, State& state, const LoadState& load) : model_(model), state_(state), load_(load) {
        check_state(model, state);
        if (model.n_dofs == 0)
            throw std::invalid_argument("the model has no free coordinates (every node is fixed): there is no "
                                        "motion to analyse");
    }
    std::unique_ptr<Run> start(const Drive& drive, Mode mode) override {
        check_state(model_, state_);
        return std::make_unique<ElementRun>(model_, state_, load_, drive, mode);
    }
    void static_policy(StaticNewtonOptions& opt, bool mechanism) const override {
        System::static_policy(opt, mechanism);
        element_static_policy(opt);
    }
    double length_scale() const override { return model_length_scale(model_); }
    std::unique_ptr<RotatingSystem> rotating(const RotationHinge& hinge, double mdot, Eigen::VectorXd& pin,
                                             Eigen::VectorXd& lam) override {
        check_state(model_, state_);
        LoadState load = load_;
        load.mass_flow = mdot;
        lam.resize(0);
        return rotating_elements(model_, state_, load, model_length_scale(model_), hinge, pin);
    }
    int n_coordinates() const override { return model_.n_dofs; }
    Eigen::VectorXd length_coordinates() const override { return element_length_coordinates(model_); }
    const State* element_state() const override { return &state_; }
    double record_size() const override { return 18.0 * model_.n_nodes() + 5.0; }

   private:
    const Model& model_;
    State& state_;
    LoadState load_;
};

}  // namespace

std::unique_ptr<System> element_system(const Model& model, State& state, const LoadState& load) {
    return std::make_unique<ElementSystem>(model, state, load);
}

}  // namespace pipeflex
