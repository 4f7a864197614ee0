// The analyses on any System: static equilibrium, linearisation, generalised-alpha.
#include "pipeflex/solvers/system.hpp"

#include "pipeflex/core/format.hpp"
#include "pipeflex/solvers/element_equations.hpp"

#include <cmath>
#include <stdexcept>

namespace pipeflex {

Record::Series& Record::operator()(const std::string& name, const std::vector<long>& shape) {
    for (auto& [key, s] : series)
        if (key == name) return s;
    series.emplace_back(name, Series{shape, {}});
    return series.back().second;
}

Record System::integrate_ida(const Drive&, const std::vector<double>&, const ProgressFn&) {
    throw std::invalid_argument(
        "integrator='ida' integrates an element model's ODE; a system with joints is a differential-algebraic "
        "system of index 3, which IDA does not take: use integrator='generalized_alpha'");
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

LinearMatrices linearize(System& sys, double mdot, const TransientOptions& options, double differences_step) {
    Drive drive;
    drive.mass_flow = TimeTable::constant(mdot);
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
    for (std::size_t next = 1; next < times.size(); ++next) {
        alpha.advance_to(times[next]);
        out.t.push_back(alpha.time());
        run->record(alpha.time(), out);
        if (progress) progress(alpha.time());
    }
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
    return out;
}

}  // namespace pipeflex
