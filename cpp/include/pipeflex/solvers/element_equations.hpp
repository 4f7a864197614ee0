// The element model (pipe and ANCF elements, supports eliminated) as a system of
// equations for the solvers, with the integrators' outputs and energy bookkeeping.
#pragma once

#include "pipeflex/core/format.hpp"
#include "pipeflex/errors.hpp"
#include "pipeflex/solvers/equations.hpp"
#include "pipeflex/solvers/transient.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

namespace pipeflex {

// The element model as a system of equations for the solvers (reduced coordinates z
// around a base state, chart rates), and the integrators' outputs and energy bookkeeping.
class ElementEquations final : public Equations {
   public:
    ElementEquations(const Model& m, State& s, const LoadState& load, const TimeFunctions& f, const TransientOptions& o)
        : model(m), state(s), base_load(load), flow(f.mass_flow), loads(f.load_factor), opt(o), n(m.n_dofs),
          base_q(s.q), damped(model_damped(m)) {
        if (n == 0)
            throw std::invalid_argument("the model has no free coordinates (every node is fixed): there is no "
                                        "motion to integrate");
    }

    const Model& model;
    State& state;
    LoadState base_load;
    const TimeTable& flow;
    const TimeTable& loads;
    const TransientOptions& opt;
    int n;
    Eigen::VectorXd base_q;
    const bool damped;  // an element has damping forces: the dissipated energy is integrated
    double t_set = 0.0;
    // statics' load factor (loads and gravity) if set; any real value: the arc-length
    // border differences it, beyond the loads' range
    double static_factor = std::numeric_limits<double>::quiet_NaN();
    // Statics: no hub motion (the static analyses take the state's
    // configuration as it is), and frames re-based only past pi, so that the rotation
    // vectors of the result stay what the Python analyses report (relative to the
    // state's frames) and the Newton iterates are those of a fixed chart.
    bool statics = false;
    // mdot [kg/s] if set (statics; set_static_mass_flow), else the flow's at t
    double static_mdot = std::numeric_limits<double>::quiet_NaN();
    bool predicted = false;    // geometric_stresses hold the static Newton's prediction
    std::vector<double> geometric_stresses;
    std::vector<std::vector<double>> tangent_values;  // tangents(): the assembler's CSC values
    double rebase_angle = 0.0;  // [rad] frames with |phi| beyond it are re-based by rebase()
    // the works of the fluid forces and the loads [J], and the energy the damping forces
    // dissipated [J] (>= 0; exactly 0 without damping), since the start
    double fluid_work = 0.0, load_work = 0.0, dissipated = 0.0, last_power_t = 0.0, last_fluid_power = 0.0,
           last_load_power = 0.0, last_damping_power = 0.0;
    // the work at the accumulation before the last one (output times inside a step, IDA's:
    // interpolated linearly, record_element)
    double previous_fluid_work = 0.0, previous_load_work = 0.0, previous_dissipated = 0.0, previous_power_t = 0.0;

    LoadState load_at(double t) const {
        LoadState l = base_load;
        l.mass_flow = flow.at(t);
        l.mass_flow_rate = flow.rate(t);
        l.time = statics ? 0.0 : t;  // statics: the loads at t = 0
        if (!statics) apply_hub_frame(model, l, t);
        return l;
    }

    Eigen::VectorXd full(const Eigen::VectorXd& z) const {
        Eigen::VectorXd f = Eigen::VectorXd::Zero(6 * model.n_nodes());
        add_increment(model, f, z);
        return f;
    }

    // Coordinates from the reduced z, v, a; the hub-driven nodes from their motion at t.
    void set(const Eigen::VectorXd& z, const Eigen::VectorXd& v, const Eigen::VectorXd& a, double t) {
        set_state_coordinates(model, base_q, z, v, a, state);
        if (!statics) apply_hub(model, state, t);
        t_set = t;
    }

    double load_factor(double t) const { return loads.at(t); }

    Eigen::VectorXd residual(double t) const {
        Eigen::VectorXd r;
        assemble(model, state, load_at(t), load_factor(t), 0.0, 0.0, 0.0, &r, nullptr);
        return r;
    }

    // Re-base the frames (nodes with |phi| > angle); returns the new reduced velocity and
    // acceleration (into v and a: no allocation per step) and resets the base so that z = 0.
    // The nodes' kinematics of the step's work (accept) are taken if still those of the state.
    int rebase(double angle, Eigen::VectorXd& v, Eigen::VectorXd& a) {
        const int k = rebase_frames(state, angle, motions_current() ? motions_.data() : nullptr);
        base_q = state.q;
        reduce(model, state.v, v);
        reduce(model, state.a, a);
        return k;
    }

    // Equations
    int n_coordinates() const override { return n; }
    double length_scale() const override { return opt.length_scale; }
    // rotations and ANCF slopes (slots 3-5 of a node) count at 4/27 of the length of the
    // node's longest element (its span, at most the model size): with the nodes' positions
    // held, an angle error e bends the element's cubic Hermite field by e l xi (1 - xi)^2,
    // at most 4/27 e l (xi = 1/3), while the nodes' positions, coordinates themselves,
    // carry the rest of the motion (a rigid turn of the model included). At the whole
    // span the rotations of the stiff bending modes a flow start rings held the step there
    // (the peer's scene at rtol 1e-4: 3040 steps, 2335 at 4/27, the tip 9.0e-5 m off). The
    // model size would count the rotations of the short elements' stiff modes a step start
    // rings 1/(element length) times over and resolve them long after their displacements
    // meet the tolerance (what a mesh for Richardson extrapolation needs: every mode
    // resolved; opt.rotation_error_length > 0 gives that length). A node without
    // elements, and a combined basis column, as a displacement.
    void error_scales(Eigen::VectorXd& s) const override {
        constexpr double kHermiteReach = 4.0 / 27.0;  // max of xi (1 - xi)^2 on [0, 1]
        s = Eigen::VectorXd::Ones(n);
        if (model.full_slot.empty()) return;
        if (opt.rotation_error_length > 0.0) {
            for (int k = 0; k < n; ++k)
                if (model.full_slot[k] % 6 >= 3) s[k] = opt.rotation_error_length;
            return;
        }
        std::vector<double> span(model.n_nodes(), 0.0);
        for (const auto& e : model.elements) {
            const auto& nodes = e->nodes();
            double d = 0.0;
            for (std::size_t i = 0; i < nodes.size(); ++i)
                for (std::size_t j = i + 1; j < nodes.size(); ++j) {
                    const Vec3<double> dx = model.positions[nodes[j]] - model.positions[nodes[i]];
                    d = std::max(d, std::sqrt(dot(dx, dx)));
                }
            for (const int node : nodes) span[node] = std::max(span[node], d);
        }
        for (int k = 0; k < n; ++k) {
            const int slot = model.full_slot[k];
            if (slot % 6 >= 3 && span[slot / 6] > 0.0) s[k] = kHermiteReach * std::min(span[slot / 6], opt.length_scale);
        }
    }
    // the largest node displacement from its reference position (a hub model's: in the hub's frame)
    double motion_size() const override {
        double d2 = 0.0;
        for (int i = 0; i < model.n_nodes(); ++i) {
            double s = 0.0;
            for (int k = 0; k < 3; ++k) {
                const double d = state.q[6 * i + k] - model.positions[i][k];
                s += d * d;
            }
            d2 = std::max(d2, s);
        }
        return std::sqrt(d2);
    }
    void set(const Eigen::VectorXd& z, const Eigen::VectorXd& v, const Eigen::VectorXd& a, const Eigen::VectorXd&,
             double t) override {
        set(z, v, a, t);
    }
    // The loads of evaluate() at the state set, and their factor lf.
    LoadState evaluated_load(double* lf) const {
        LoadState l = load_at(t_set);
        *lf = load_factor(t_set);
        if (!std::isnan(static_mdot)) {
            l.mass_flow = static_mdot;
            l.mass_flow_rate = 0.0;
        }
        if (!std::isnan(static_factor)) {  // statics: loads and gravity stepped together
            l.gravity_factor *= static_factor;
            *lf = static_factor;
        }
        return l;
    }
    void evaluate(double wK, double wC, double wM, Eigen::VectorXd& r, Triplets* J) override {
        double lf;
        const LoadState l = evaluated_load(&lf);
        const bool mixed = predicted && J != nullptr;
        assemble(model, state, l, lf, wK, wC, wM, &r, J, mixed ? geometric_stresses.data() : nullptr);
    }
    // K, C and an iteration matrix in one pass of the assembler on the model's pattern
    void tangents(const std::vector<TangentWeights>& weights, std::vector<Triplets>& J) override {
        double lf;
        const LoadState l = evaluated_load(&lf);
        const std::shared_ptr<const TangentPattern> pattern = tangent_pattern(model);
        const std::size_t nnz = pattern->row_index.size();
        tangent_values.resize(weights.size());
        std::vector<double*> out;
        for (auto& v : tangent_values) {
            v.resize(nnz);
            out.push_back(v.data());
        }
        assemble_csc(model, state, l, lf, weights, nullptr, out.data());
        J.resize(weights.size());
        for (std::size_t w = 0; w < weights.size(); ++w) {
            Triplets& t = J[w];
            t.rows.resize(nnz);
            t.cols.resize(nnz);
            t.values.assign(tangent_values[w].begin(), tangent_values[w].end());
            for (int c = 0; c < n; ++c)
                for (int k = pattern->col_ptr[c]; k < pattern->col_ptr[c + 1]; ++k) {
                    t.rows[k] = pattern->row_index[k];
                    t.cols[k] = c;
                }
        }
    }
    // on the model's pattern (tangent_pattern), no triplets
    void tangents_csc(const std::vector<TangentWeights>& weights, TangentCsc& out) override {
        out.assemble(n, 0, static_cast<int>(weights.size()), tangent_pattern(model),
                     [&](const int* slot, double* const* values) { tangents_into(weights, slot, values); }, {});
    }
    // The tangents of the weights at the state set added to values[i] at slot[k] for the
    // assembler's k-th entry (TangentCsc::BlockFill: the model's pattern within a larger one).
    void tangents_into(const std::vector<TangentWeights>& weights, const int* slot, double* const* values) {
        double lf;
        const LoadState l = evaluated_load(&lf);
        assemble_csc(model, state, l, lf, weights, nullptr, values, nullptr, slot);
    }
    void set_static_load_factor(double f) override { static_factor = f; }
    void set_static_mass_flow(double mdot) override { static_mdot = mdot; }
    // The static Newton on pipe elements is the mixed Newton (Equations::predict_stresses).
    // Only the tangent changes, so the equilibrium is the same; a large first correction
    // from the straight state no longer leaves the next tangent stiffened by a spurious
    // axial force, whose size grows with the mesh (bench_analyses_scaling: static (tip load)).
    void predict_stresses(const Eigen::VectorXd* dz) override {
        predicted = dz != nullptr && model.n_stresses > 0;
        if (predicted) predicted_stresses(model, state, full(dz->head(n)), geometric_stresses);
    }
    int rebase(Eigen::VectorXd& v, Eigen::VectorXd& a) override { return rebase(rebase_angle, v, a); }
    double chart_rotation() const override { return state.max_rotation(); }
    void set_rebase_angle(double angle) override { rebase_angle = angle; }
    // a fine mesh started off balance rings in its stiff modes (bench_galpha_step.py)
    bool adaptive_prediction() const override { return true; }
    void accept(double t, double h) override {
        check_divergence(t, h);
        accumulate_work(t);
    }
    double mass_flow(double t) const override { return load_at(t).mass_flow; }
    std::string singular_mass_hint() const override {
        return "some coordinates have no inertia (e.g. torsion or rotation about the pipe axis without rotary "
               "inertia). Give the sections rotary_inertia, or constrain those coordinates.";
    }

    // Throws when a node has moved farther than divergence_limit length scales from its
    // reference position, or the state is not finite (call after set()).
    void check_divergence(double t, double h) const {
        const double lim = opt.divergence_limit * opt.length_scale;
        for (int i = 0; i < model.n_nodes(); ++i) {
            double d2 = 0.0;
            bool finite = true;
            for (int k = 0; k < 3; ++k) {
                const double d = state.q[6 * i + k] - model.positions[i][k];
                d2 += d * d;
                finite = finite && std::isfinite(state.q[6 * i + k]) && std::isfinite(state.v[6 * i + k]);
            }
            if (!finite || std::sqrt(d2) > lim) {
                std::ostringstream os;
                os << "the motion diverged at t = " << t << " s (step " << h << " s): node " << i
                   << (finite ? " moved " + fmt(std::sqrt(d2)) + " m from its reference position (limit " +
                                    fmt(lim) + " m)"
                              : " has a non-finite position or velocity");
                ConvergenceError::Where where;
                where.time = t;
                where.mass_flow = load_at(t).mass_flow;
                throw ConvergenceError(os.str(), where);
            }
        }
    }

    // Power of the fluid forces and of the external loads on the structure [W], and the
    // power the damping forces dissipate [W] (0 without damping: no work done).
    void powers(double t, double* fluid, double* loads, double* damping) {
        *fluid = fluid_power(model, state, load_at(t), state_motions());
        // state.v is B v_z, so v . f equals v_z . B^T f
        *loads = load_factor(t) * load_power(model, state, t);
        *damping = damped ? damping_power(model, state) : 0.0;
    }

    void start_work(double t) {
        if (!opt.work) return;
        powers(t, &last_fluid_power, &last_load_power, &last_damping_power);
        last_power_t = t;
    }

    // Trapezoidal accumulation of the work from the last step to time t (current state).
    void accumulate_work(double t) {
        if (!opt.work) return;
        double pf, pl, pd;
        powers(t, &pf, &pl, &pd);
        const double dt = t - last_power_t;
        previous_fluid_work = fluid_work;
        previous_load_work = load_work;
        previous_dissipated = dissipated;
        previous_power_t = last_power_t;
        fluid_work += 0.5 * dt * (pf + last_fluid_power);
        load_work += 0.5 * dt * (pl + last_load_power);
        if (damped) dissipated += 0.5 * dt * (pd + last_damping_power);
        last_fluid_power = pf;
        last_load_power = pl;
        last_damping_power = pd;
        last_power_t = t;
    }

    // node_motion of every frame node at the state (node_motions), evaluated once per state:
    // the step's work (accept) and the re-basing that follows take the same.
    const NodeMotion<double>* state_motions() {
        if (!motions_current()) {
            node_motions(model, state, motions_);
            motions_q_ = state.q;
            motions_v_ = state.v;
            motions_a_ = state.a;
        }
        return motions_.data();
    }
    // whether motions_ are those of the state (whoever changed it since)
    bool motions_current() const {
        auto same = [](const Eigen::VectorXd& x, const Eigen::VectorXd& y) {  // bit for bit
            return x.size() == y.size() &&
                   std::memcmp(x.data(), y.data(), static_cast<std::size_t>(x.size()) * sizeof(double)) == 0;
        };
        return !motions_.empty() && same(motions_q_, state.q) && same(motions_v_, state.v) &&
               same(motions_a_, state.a);
    }

    // fw, lw, dw: the works of the fluid and the loads and the dissipated energy at t [J]
    void record(double t, TransientOutput& out, double fw, double lw, double dw) const {
        out.t.push_back(t);
        const int N = model.n_nodes();
        for (int i = 0; i < N; ++i) {
            const Vec3<double> phi{{state.q[6 * i + 3], state.q[6 * i + 4], state.q[6 * i + 5]}};
            const Vec3<double> phid{{state.v[6 * i + 3], state.v[6 * i + 4], state.v[6 * i + 5]}};
            Vec3<double> w = rotation_jacobian(phi) * phid;
            if (state.kinds[i] == NodeKind::ancf) w = (1.0 / dot(phi, phi)) * cross(phi, phid);  // slope's turn rate
            const Mat3<double> R = state.rotation(i);
            for (int k = 0; k < 3; ++k) {
                out.x.push_back(state.q[6 * i + k]);
                out.xd.push_back(state.v[6 * i + k]);
                out.w.push_back(w[k]);
            }
            for (int k = 0; k < 9; ++k) out.R.push_back(R.c[k]);
        }
        double T, U;
        energies(model, state, &T, &U);
        out.kinetic.push_back(T);
        out.elastic.push_back(U);
        out.gravity_potential.push_back(gravity_potential(model, state, load_at(t)));
        out.fluid_work.push_back(fw);
        out.load_work.push_back(lw);
        out.dissipated.push_back(dw);
    }

   private:
    // state_motions(): the nodes' kinematics and the state (q, v, a) they were evaluated at
    std::vector<NodeMotion<double>> motions_;
    Eigen::VectorXd motions_q_, motions_v_, motions_a_;
};

// The element model's equations for statics, with the flow and options they refer to:
// mdot constant at load.mass_flow [kg/s], loads and gravity times the static load factor
// (set_static_load_factor), frames re-based past pi only, length_scale [m] the model
// size of the correction test. Checks the state; the model must have free coordinates.
struct ElementStatics {
    TimeFunctions functions;
    TransientOptions options;
    ElementEquations eq;
    ElementStatics(const Model& model, State& state, const LoadState& load, double length_scale)
        : functions{TimeTable::constant(load.mass_flow), TimeTable::constant(1.0)},
          options(scaled(length_scale)),
          eq(checked(model, state), state, unit_gravity(load), functions, options) {
        eq.statics = true;
        eq.rebase_angle = M_PI;
        eq.static_mdot = load.mass_flow;
    }

   private:
    static const Model& checked(const Model& model, const State& state) {
        check_state(model, state);
        return model;
    }
    static TransientOptions scaled(double length_scale) {
        TransientOptions o;
        o.length_scale = length_scale;
        return o;
    }
    static LoadState unit_gravity(const LoadState& load) {
        LoadState base = load;
        base.gravity_factor = 1.0;  // gravity, as the loads, times the static load factor
        return base;
    }
};

// The generalised-alpha options of a run's transient options.
inline AlphaOptions alpha_options(const TransientOptions& opt) {
    AlphaOptions a;
    a.step = opt.step;
    a.min_step = opt.min_step;
    a.rho_inf = opt.rho_inf;
    a.newton_tol = opt.newton_tol;
    a.max_newton = opt.max_newton;
    a.max_steps = opt.max_steps;
    a.error_rate = opt.error_rate;
    a.motion_rate = opt.motion_rate;
    a.error_per_step = opt.error_per_step;
    a.steps = opt.steps;
    return a;
}

// The integrator's work counters in an element run's output.
inline void put_stats(const AlphaStats& st, TransientOutput& out) {
    out.steps = st.steps;
    out.newton_iterations = st.newton_iterations;
    out.jacobians = st.jacobians;
    out.rebases = st.rebases;
    out.convergence_failures = st.failed_steps;
}

}  // namespace pipeflex
