// The analyses on any System: static equilibrium, linearisation, generalised-alpha.
#include "pipeflex/solvers/system.hpp"

#include "pipeflex/core/format.hpp"
#include "pipeflex/solvers/element_equations.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"

#include <cmath>
#include <stdexcept>

namespace pipeflex {

Record::Series& Record::operator()(const std::string& name, const std::vector<long>& shape) {
    for (auto& [key, s] : series)
        if (key == name) return s;
    series.emplace_back(name, Series{shape, {}});
    return series.back().second;
}

StaticNewtonResult static_equilibrium(System& sys, double mdot, double load_factor, StaticNewtonOptions opt,
                                      const TransientOptions& options, bool mechanism) {
    Drive drive;
    drive.mass_flow = TimeTable::constant(mdot);
    drive.options = options;
    sys.static_policy(opt, mechanism);
    const std::unique_ptr<Run> run = sys.start(drive, System::Mode::statics);
    Equations& eq = run->equations();
    eq.set_static_load_factor(load_factor);
    Eigen::VectorXd lam = run->lam;
    const StaticNewtonResult res = static_newton(eq, run->t0, lam, opt);
    run->lam = lam;
    run->finish();
    return res;
}

namespace {

void check_arc(const System& sys, const Eigen::VectorXd& w2, const Eigen::VectorXd& dq, const char* name) {
    const int n = sys.n_coordinates();
    if (w2.size() != n || dq.size() != n)
        throw std::invalid_argument(std::string("the arc's weights w2 and ") + name + " must have " +
                                    std::to_string(n) + " entries (the system's coordinates)");
}

Drive static_drive(double mdot, const TransientOptions& options) {
    Drive drive;
    drive.mass_flow = TimeTable::constant(mdot);
    drive.options = options;
    return drive;
}

}  // namespace

StaticNewtonResult static_arc_newton(System& sys, const ArcPath& path, const Eigen::VectorXd& w2, double psi2,
                                     double ds, double& tau, Eigen::VectorXd& dq, double& dtau,
                                     StaticNewtonOptions opt, const TransientOptions& options, bool predict) {
    check_arc(sys, w2, dq, "dq");
    sys.static_policy(opt, false);
    const std::unique_ptr<Run> run = sys.start(static_drive(path.m0 + path.m1 * tau, options), System::Mode::statics);
    Equations& eq = run->equations();
    const int n = eq.n_coordinates();
    Eigen::VectorXd lam = run->lam, v = Eigen::VectorXd::Zero(n), a = Eigen::VectorXd::Zero(n);
    if (predict && dq.any()) {  // the predictor: the state moved by dq, the new base
        eq.set(dq, v, a, lam, run->t0);
        eq.rebase(v, a);
    }
    ArcBorder arc(eq, path, w2, dq, psi2, ds, tau, dtau);
    opt.border = &arc;
    const StaticNewtonResult res = static_newton(eq, run->t0, lam, opt);
    tau = arc.tau;
    dq = arc.dq;
    dtau = arc.dtau;
    run->lam = lam;
    run->finish();
    return res;
}

bool static_arc_tangent(System& sys, const ArcPath& path, double tau, const Eigen::VectorXd& w2, double psi2,
                        const Eigen::VectorXd& pq, double pt, Eigen::VectorXd& v, double& s,
                        const TransientOptions& options) {
    check_arc(sys, w2, pq, "the previous tangent");
    const std::unique_ptr<Run> run = sys.start(static_drive(path.m0 + path.m1 * tau, options), System::Mode::statics);
    Equations& eq = run->equations();
    const int n = eq.n_coordinates(), nc = eq.n_constraints(), m = n + nc;
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    ArcBorder arc(eq, path, w2, zero, psi2, 1.0, tau, 0.0);
    Eigen::VectorXd r, rp, rt;
    Triplets J;
    eq.set(zero, zero, zero, run->lam, run->t0);
    const double h = arc.difference_step();
    arc.set_parameter(tau + h);
    eq.evaluate(1.0, 0.0, 0.0, rp, nullptr);
    arc.set_parameter(tau - h);
    eq.evaluate(1.0, 0.0, 0.0, rt, nullptr);
    arc.set_parameter(tau);
    eq.evaluate(1.0, 0.0, 0.0, r, &J);
    rt = (rp - rt) / (2.0 * h);
    if (nc > 0) {  // scaled as static_newton's KKT matrix
        double sc = scale_constraints(J, n, 1.0);
        sc = sc > 0.0 ? sc : 1.0;
        scale_constraints(J, n, sc);
        rt.tail(nc) *= sc;
    }
    Triplets A = J;
    for (int i = 0; i < m; ++i) A.add(i, m, rt[i]);
    for (int i = 0; i < n; ++i) A.add(m, i, w2[i] * pq[i]);
    A.add(m, m, psi2 * pt);
    FixedPatternLU lu(kDenseLuBelow);
    if (!lu.factorize(m + 1, A.rows, A.cols, A.values)) return false;
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(m + 1), x;
    rhs[m] = 1.0;
    lu.solve(rhs, x);
    v = x.head(n);
    s = x[m];
    const double norm = std::sqrt(w2.cwiseProduct(v).dot(v) + psi2 * s * s);
    if (!std::isfinite(norm) || norm == 0.0) return false;
    v /= norm;
    s /= norm;
    if (w2.cwiseProduct(v).dot(pq) + psi2 * s * pt < 0.0) {
        v = -v;
        s = -s;
    }
    return true;
}

LinearMatrices linearize(System& sys, double mdot, const TransientOptions& options, double differences_step,
                         double mdot_rate) {
    Drive drive;
    drive.mass_flow = TimeTable::constant(mdot);
    if (mdot_rate != 0.0) {  // a flow leaving mdot (exactly) at the run's start t0 = 0 at the rate mdot_rate
        drive.mass_flow.t = {0.0, 1.0};
        drive.mass_flow.value = {mdot, mdot + mdot_rate};
    }
    drive.options = options;
    const std::unique_ptr<Run> run = sys.start(drive, System::Mode::dynamics);
    return linear_matrices(run->equations(), run->v, run->a, run->lam, run->t0, differences_step, &sys.tangent_csc());
}

SteadyRotationOutcome steady_rotation(System& sys, const RotationHinge& hinge, double mdot, double omega_guess,
                                      const SteadyRotationOptions& opt) {
    Eigen::VectorXd pin, lam;
    const std::unique_ptr<RotatingSystem> rot = sys.rotating(hinge, mdot, pin, lam);
    const SteadyRotationOutcome out = steady_rotation(*rot, pin, mdot, omega_guess, opt, lam);
    rot->finish(lam);
    return out;
}

Record integrate(System& sys, const Drive& drive, const std::vector<double>& times, const ProgressFn& progress) {
    Record out;
    if (times.empty()) return out;
    const std::unique_ptr<Run> run = sys.start(drive, System::Mode::dynamics);
    const double t0 = times.front();
    GeneralizedAlpha alpha(run->equations(), alpha_options(drive.options), t0, run->v);
    run->begin(t0);
    out.t.push_back(t0);
    run->record(t0, out);
    std::unique_ptr<SensorRecorder> sensors;
    if (drive.sensors != nullptr && !drive.sensors->empty()) {
        sensors = std::make_unique<SensorRecorder>(*run, *drive.sensors);
        sensors->step(t0);
        run->equations().observer = sensors.get();
    }
    for (std::size_t next = 1; next < times.size(); ++next) {
        try {
            alpha.advance_to(times[next]);
        } catch (const TerminalEvent&) {  // a terminal crossing: the run ends with its step (the state set there)
            out.t.push_back(alpha.time());
            run->record(alpha.time(), out);
            break;
        }
        out.t.push_back(alpha.time());
        run->record(alpha.time(), out);
        if (progress) progress(alpha.time());
    }
    run->equations().observer = nullptr;
    run->finish();
    const AlphaStats& st = alpha.stats();
    // one vocabulary with IDA's (TransientOutput): a halved step is a convergence failure,
    // a step redone for its error estimate an error-test failure
    out.counters = {{"steps", st.steps},         {"newton_iterations", st.newton_iterations},
                    {"jacobians", st.jacobians}, {"rebases", st.rebases},
                    {"failed_steps", st.rejected_steps}, {"convergence_failures", st.failed_steps}};
    if (drive.options.error_rate > 0.0)
        out.estimates = {{"error_sum", st.error_sum},
                         {"error_max", st.error_max},
                         {"smallest_step", st.smallest_step},
                         {"largest_step", st.largest_step}};
    out.steps = alpha.steps_taken();
    return out;
}

}  // namespace pipeflex
