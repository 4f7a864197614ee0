#include "convert.hpp"
#include "outputs.hpp"
#include "pipeflex/core/format.hpp"
#include "pipeflex/solvers/coupled.hpp"
#include "pipeflex/solvers/element_equations.hpp"
#include "pipeflex/solvers/rigid_rotation.hpp"
#include "pipeflex/solvers/rotating_systems.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"
#include "pipeflex/solvers/transient.hpp"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>

namespace py = pybind11;

namespace {
// The element statics' Newton options (the Python loop's tests): converged on the
// correction or the force level, the converged correction applied, divergence judged
// from the second correction on.
pipeflex::StaticNewtonOptions element_static_options(double tol, double force_scale, int max_iterations) {
    pipeflex::StaticNewtonOptions opt;
    opt.tol = tol;
    opt.max_iterations = max_iterations;
    opt.force_scale = force_scale;
    opt.apply_converged_correction = true;
    opt.divergence_from = 2;
    return opt;
}
}  // namespace
using namespace pipeflex;

namespace {

py::array_t<double> as_array(const std::vector<double>& v, std::vector<py::ssize_t> shape) {
    py::array_t<double> a(shape);
    std::copy(v.begin(), v.end(), a.mutable_data());
    return a;
}

// The work counters that both integrators' outputs have.
template <class Output> void put_counters(py::dict& d, const Output& out) {
    d["steps"] = out.steps;
    d["newton_iterations"] = out.newton_iterations;
    d["jacobians"] = out.jacobians;
}

using Integrator = TransientOutput (*)(const Model&, State&, const LoadState&, const TimeFunctions&,
                                       const std::vector<double>&, const TransientOptions&, const ProgressFn&);

// Largest output of one run [bytes]: the arrays of x, R, xd, omega (18 values per node)
// and five energies per output time, allocated up front by the caller's numpy arrays.
constexpr double kMaxOutputBytes = 2.0 * (1 << 30);

// Checks before any work: the state fits the model, the output times are increasing and
// finite, the output fits in memory and, for generalised-alpha (fixed step, so its step
// count is known in advance), the steps to the last output are at most max_steps.
void check_run(const Model& model, const State& state, const std::vector<double>& times,
               const TransientOptions& opt, bool fixed_step) {
    check_state(model, state);
    if (times.size() < 2) throw std::invalid_argument("times must hold at least 2 output times");
    for (std::size_t k = 0; k < times.size(); ++k) {
        if (!std::isfinite(times[k])) throw std::invalid_argument("times must be finite");
        if (k > 0 && !(times[k] > times[k - 1])) throw std::invalid_argument("times must be strictly increasing");
    }
    const double bytes = 8.0 * static_cast<double>(times.size()) * (18.0 * model.n_nodes() + 5.0);
    if (bytes > kMaxOutputBytes)
        throw std::invalid_argument("n_outputs: " + std::to_string(times.size()) + " output times of " +
                                    std::to_string(model.n_nodes()) + " nodes need " + fmt(bytes / (1 << 30)) +
                                    " GiB; at most " + fmt(kMaxOutputBytes / (1 << 30)) +
                                    " GiB (fewer outputs, or split the run)");
    if (opt.max_steps < 1) throw std::invalid_argument("max_steps must be >= 1");
    if (!fixed_step) return;
    if (!(opt.step > 0.0) || !std::isfinite(opt.step)) throw std::invalid_argument("step must be > 0 and finite");
    // the integrator's equal steps per output interval: ceil(interval / step) each
    double steps = 0.0;
    for (std::size_t k = 1; k < times.size(); ++k) steps += std::ceil((times[k] - times[k - 1]) / opt.step - 1e-9);
    if (steps > static_cast<double>(opt.max_steps))
        throw std::invalid_argument("step = " + fmt(opt.step) + " s gives " + fmt(steps) + " steps from t = " +
                                    fmt(times.front()) + " s to " + fmt(times.back()) + " s; max_steps = " +
                                    std::to_string(opt.max_steps) + " (raise step or max_steps, or shorten the run)");
}

// Couplings from Python: (element node, kind 0 rigid / 1 hinge / 2 spherical, body, body
// node, C0, axis_b, perp0, perp1) tuples.
std::vector<Coupling> couplings_from(const py::list& couplings) {
    std::vector<Coupling> cp;
    for (const py::handle& h : couplings) {
        const py::tuple c = py::reinterpret_borrow<py::tuple>(h);
        Coupling k;
        k.element_node = c[0].cast<int>();
        const int kind = c[1].cast<int>();
        if (kind < 0 || kind > 2) throw std::invalid_argument("coupling kind must be 0 (rigid), 1 (hinge) or 2 (spherical)");
        k.joint.kind = static_cast<JointKind>(kind);
        k.joint.body_b = c[2].cast<int>();
        k.joint.node_b = c[3].cast<int>();
        k.joint.C0 = c[4].cast<Mat3d>();
        k.joint.axis_b = c[5].cast<Vec3d>();
        k.joint.perp_a = {c[6].cast<Vec3d>(), c[7].cast<Vec3d>()};
        cp.push_back(k);
    }
    return cp;
}

// A Python callable (or None) as the integrators' progress callback, taking the GIL, called
// at most every 0.1 s of wall time: a progress bar needs no more, and a call with the GIL
// costs about 1 us, which every output time paid (the callers report the end themselves).
ProgressFn progress_callback(py::object progress) {
    if (progress.is_none()) return {};
    using clock = std::chrono::steady_clock;
    auto last = std::make_shared<clock::time_point>(clock::now());
    return [progress, last](double t) {
        const clock::time_point now = clock::now();
        if (now - *last < std::chrono::milliseconds(100)) return;
        *last = now;
        py::gil_scoped_acquire gil;
        progress(t);
    };
}

// steady_rotation's options and outcome
SteadyRotationOptions steady_options(double tol, int max_iterations, int dense_below) {
    SteadyRotationOptions opt;
    opt.tol = tol;
    opt.max_iterations = max_iterations;
    opt.dense_below = dense_below;
    return opt;
}
py::dict steady_dict(const SteadyRotationOutcome& out) {
    py::dict d;
    d["converged"] = out.converged;
    d["singular"] = out.singular;
    d["omega"] = out.omega;
    d["iterations"] = out.iterations;
    d["residual"] = out.residual;
    return d;
}
RotationHinge rotation_hinge(const Vec3d& point, const Vec3d& axis, int body, int element_dof) {
    RotationHinge h;
    h.point = point;
    h.axis = axis;
    h.body = body;
    h.element_dof = element_dof;
    return h;
}

py::dict run(Integrator f, const Model& model, State& state, const LoadState& load, const TimeTable& flow,
             const TimeTable& loads, const std::vector<double>& times, const TransientOptions& opt,
             py::object progress) {
    check_run(model, state, times, opt, f == integrate_generalized_alpha);
    const ProgressFn cb = progress_callback(progress);
    TransientOutput out;
    {
        py::gil_scoped_release release;
        out = f(model, state, load, TimeFunctions{flow, loads}, times, opt, cb);
    }
    return transient_dict(out, model.n_nodes());
}

}  // namespace

py::dict pipeflex::transient_dict(const TransientOutput& out, py::ssize_t N) {
    const py::ssize_t nt = static_cast<py::ssize_t>(out.t.size());
    py::dict d;
    d["t"] = as_array(out.t, {nt});
    d["x"] = as_array(out.x, {nt, N, 3});
    d["R"] = as_array(out.R, {nt, N, 3, 3});
    d["xd"] = as_array(out.xd, {nt, N, 3});
    d["omega"] = as_array(out.w, {nt, N, 3});
    d["kinetic"] = as_array(out.kinetic, {nt});
    d["elastic"] = as_array(out.elastic, {nt});
    d["gravity_potential"] = as_array(out.gravity_potential, {nt});
    d["fluid_work"] = as_array(out.fluid_work, {nt});
    d["load_work"] = as_array(out.load_work, {nt});
    put_counters(d, out);
    d["rebases"] = out.rebases;
    d["failed_steps"] = out.failed_steps;
    d["convergence_failures"] = out.convergence_failures;
    return d;
}

void bind_transient(py::module_& m) {
    m.def(
        "_fixed_pattern_lu",
        [](int n, const std::vector<int>& rows, const std::vector<int>& cols, const std::vector<double>& values,
           const Eigen::VectorXd& rhs, int dense_below, bool band_first) {
            // the tests' handle on the integrators' LU: the storage chosen and a solve
            pipeflex::FixedPatternLU lu(dense_below, band_first);
            const bool ok = lu.factorize(n, rows, cols, values);
            Eigen::VectorXd x;
            if (ok) lu.solve(rhs, x);
            const char* names[] = {"dense", "band", "sparse"};
            return py::make_tuple(std::string(names[static_cast<int>(lu.storage())]), ok, x);
        },
        py::arg("n"), py::arg("rows"), py::arg("cols"), py::arg("values"), py::arg("rhs"), py::arg("dense_below"),
        py::arg("band_first"),
        "FixedPatternLU on triplets (repeats summed): (storage 'dense' | 'band' | 'sparse', factorised, x = A^-1 rhs).");
    py::class_<TimeTable>(m, "TimeTable")
        .def(py::init<>())
        .def_readwrite("t", &TimeTable::t)
        .def_readwrite("value", &TimeTable::value)
        .def_readwrite("omega", &TimeTable::omega)
        .def_readwrite("phase", &TimeTable::phase)
        .def("at", &TimeTable::at, py::arg("time"), "The function's value at time [s].")
        .def("rate", &TimeTable::rate, py::arg("time"), "The function's derivative at time [s] (per second).");
    py::class_<TransientOptions>(m, "TransientOptions")
        .def(py::init<>())
        .def_readwrite("rtol", &TransientOptions::rtol)
        .def_readwrite("atol", &TransientOptions::atol)
        .def_readwrite("max_order", &TransientOptions::max_order)
        .def_readwrite("step", &TransientOptions::step)
        .def_readwrite("min_step", &TransientOptions::min_step)
        .def_readwrite("rho_inf", &TransientOptions::rho_inf)
        .def_readwrite("newton_tol", &TransientOptions::newton_tol)
        .def_readwrite("max_newton", &TransientOptions::max_newton)
        .def_readwrite("max_steps", &TransientOptions::max_steps)
        .def_readwrite("rebase_angle", &TransientOptions::rebase_angle)
        .def_readwrite("length_scale", &TransientOptions::length_scale)
        .def_readwrite("divergence_limit", &TransientOptions::divergence_limit)
        .def_readwrite("work", &TransientOptions::work);
    for (const auto& [name, integrator] : {std::pair{"integrate_ida", &integrate_ida},
                                           std::pair{"integrate_generalized_alpha", &integrate_generalized_alpha}}) {
        m.def(name, [f = integrator](const Model& md, State& s, const LoadState& l, const TimeTable& flow,
                                     const TimeTable& lf, const std::vector<double>& t, const TransientOptions& o,
                                     py::object p) { return run(f, md, s, l, flow, lf, t, o, p); },
              py::arg("model"), py::arg("state"), py::arg("load"), py::arg("mass_flow"), py::arg("load_factor"),
              py::arg("times"), py::arg("options"), py::arg("progress"),
              "A transient run from the state (updated in place) with the mass flow [kg/s] and load factor as "
              "functions of time, output at times [s]; progress: None or a callable of the time [s].");
    }
    m.def(
        "integrate_coupled",
        [](const Model& md, State& s, const LoadState& l, const TimeTable& flow, const TimeTable& lf,
           const MultibodySystemCore& bodies, const Arr& r, const Arr& R, const VecX& eta, const VecX& v,
           const py::list& couplings, const std::vector<double>& times, const TransientOptions& o, py::object progress) {
            check_run(md, s, times, o, true);
            MbState bs = to_state(bodies, r, R, eta, v, VecX::Zero(v.size()), VecX::Zero(bodies.n_constraints()),
                                  times.empty() ? 0.0 : times.front());
            const std::vector<Coupling> cp = couplings_from(couplings);
            const ProgressFn cb = progress_callback(progress);
            CoupledOutput out;
            {
                py::gil_scoped_release release;
                out = integrate_coupled(md, s, l, TimeFunctions{flow, lf}, bodies, bs, cp, times, o, cb);
            }
            py::dict d = transient_dict(out.elements, md.n_nodes());
            py::list states, lams;
            for (const auto& st : out.bodies) states.append(from_state(st));
            for (const auto& lam : out.coupling_multipliers) lams.append(lam);
            d["bodies"] = states;
            d["coupling_multipliers"] = lams;
            return d;
        },
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("mass_flow"), py::arg("load_factor"),
        py::arg("bodies"), py::arg("r"), py::arg("R"), py::arg("eta"), py::arg("v"), py::arg("couplings"),
        py::arg("times"), py::arg("options"), py::arg("progress") = py::none());
    m.def(
        "coupled_static",
        [](const Model& md, State& s, const LoadState& l, const MultibodySystemCore& bodies, const Arr& r,
           const Arr& R, const VecX& eta, const VecX& lam, const py::list& couplings, VecX coupling_lam,
           double load_factor, const TransientOptions& o, double tol, int max_iterations) {
            check_state(md, s);
            MbState bs = to_state(bodies, r, R, eta, VecX::Zero(eta.size()), VecX::Zero(eta.size()), lam, 0.0);
            const std::vector<Coupling> cp = couplings_from(couplings);
            StaticNewtonResult res;
            {
                py::gil_scoped_release release;
                res = coupled_static(md, s, l, bodies, bs, cp, coupling_lam, load_factor, o, tol, max_iterations);
            }
            py::dict d = static_dict(res);
            d["bodies"] = from_state(bs);
            d["coupling_multipliers"] = coupling_lam;
            return d;
        },
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("bodies"), py::arg("r"), py::arg("R"),
        py::arg("eta"), py::arg("lam"), py::arg("couplings"), py::arg("coupling_lam"), py::arg("load_factor"),
        py::arg("options"), py::arg("tol"), py::arg("max_iterations"));
    m.def(
        "coupled_linear_matrices",
        [](const Model& md, State& s, const LoadState& l, const MultibodySystemCore& bodies, const Arr& r,
           const Arr& R, const VecX& eta, const VecX& v, const VecX& a, const VecX& lam, const py::list& couplings,
           const VecX& coupling_lam, const TransientOptions& o, double differences_step) {
            const MbState bs = to_state(bodies, r, R, eta, v, a, lam, 0.0);
            return linear_dict(coupled_linear_matrices(md, s, l, bodies, bs, couplings_from(couplings), coupling_lam, o,
                                                       differences_step));
        },
        "The linearised equations of a coupled system about the element state (re-based in place) and the body "
        "state: K, C, M and C_q as triplets, coordinates [z_el; q_b].",
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("bodies"), py::arg("r"), py::arg("R"),
        py::arg("eta"), py::arg("v"), py::arg("a"), py::arg("lam"), py::arg("couplings"), py::arg("coupling_lam"),
        py::arg("options"), py::arg("differences_step") = 0.0);
    m.def(
        "element_linear_matrices",
        [](const Model& md, State& s, const LoadState& l, const TransientOptions& o, double differences_step) {
            return linear_dict(element_linear_matrices(md, s, l, o, differences_step));
        },
        "The element model's linearised equations by the generic route (linear_matrices on its equations), "
        "with differences_step > 0 also the residual's central differences: tests.",
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("options"), py::arg("differences_step") = 0.0);
    py::class_<FlowMapTangent, std::shared_ptr<FlowMapTangent>>(
        m, "FlowMapTangent",
        "The tangent-linear map d(z, v)_end / d(z0, v0) of a flow map, kept step by step.")
        .def("apply",
             [](const FlowMapTangent& t, const Eigen::MatrixXd& directions) {
                 py::gil_scoped_release release;
                 return t.apply(directions);
             },
             py::arg("directions"), "(2n, p) directions [dz0; dv0] -> (2n, p) [dz; dv] at the end")
        .def_property_readonly("dimension", &FlowMapTangent::dimension)
        .def_property_readonly("nbytes", &FlowMapTangent::bytes);
    m.def(
        "generalized_alpha_flow_map",
        [](const Model& md, State& s, const LoadState& l, const Eigen::VectorXd& z0, const Eigen::VectorXd& v0,
           double duration, int n_steps, bool sensitivity, const TransientOptions& o, bool monodromy) {
            check_state(md, s);
            FlowMapOutput out;
            Eigen::MatrixXd Phi;
            {
                py::gil_scoped_release release;
                out = generalized_alpha_flow_map(md, s, l, z0, v0, duration, n_steps, sensitivity, o);
                if (sensitivity && monodromy) Phi = out.tangent->apply(Eigen::MatrixXd::Identity(2 * md.n_dofs, 2 * md.n_dofs));
            }
            py::dict d;
            d["z"] = as_array(out.z, {static_cast<py::ssize_t>(n_steps) + 1, md.n_dofs});
            d["v"] = out.v;
            d["a"] = out.a;
            d["a0"] = out.a0;
            if (sensitivity) {
                d["tangent"] = out.tangent;
                if (monodromy) d["monodromy"] = Phi;
            }
            put_counters(d, out);
            return d;
        },
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("z0"), py::arg("v0"), py::arg("duration"),
        py::arg("n_steps"), py::arg("sensitivity"), py::arg("options"), py::arg("monodromy") = true);
    m.attr("MAX_OUTPUT_BYTES") = kMaxOutputBytes;  // pipeflex._checks.output_count checks it before allocating
    m.def(
        "static_newton",
        [](const Model& md, State& s, const LoadState& load, double load_factor, double tol, double length_scale,
           double force_scale, int max_iterations, bool inertia) {
            StaticNewtonOptions opt = element_static_options(tol, force_scale, max_iterations);
            opt.inertia = inertia;
            StaticNewtonResult res;
            {
                py::gil_scoped_release release;
                res = element_static(md, s, load, load_factor, length_scale, opt);
            }
            return static_dict(res);
        },
        "Static equilibrium of an element model by Newton's method (the core's static_newton) from the state "
        "(updated in place), under the load state and load factor; tol on the correction / length_scale [m] or "
        "the residual / force_scale [N]. A dict: converged, singular, diverged, nonfinite, iterations, "
        "residual [N], correction; with inertia the tangent's negative eigenvalues at the start "
        "and the converged end, negative_start and negative_end (-1: not counted).",
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("load_factor"), py::arg("tol"),
        py::arg("length_scale"), py::arg("force_scale"), py::arg("max_iterations"), py::arg("inertia") = false);
    m.def(
        "static_arc_newton",
        [](const Model& md, State& s, const LoadState& load, const std::tuple<double, double, double, double>& path,
           const Eigen::VectorXd& w2, double psi2, double ds, double tau, Eigen::VectorXd dq, double dtau,
           double tol, double length_scale, double force_scale, int max_iterations) {
            const StaticNewtonOptions opt = element_static_options(tol, force_scale, max_iterations);
            StaticNewtonResult res;
            {
                py::gil_scoped_release release;
                res = element_arc_static(md, s, load, length_scale, opt, std::get<0>(path), std::get<1>(path),
                                         std::get<2>(path), std::get<3>(path), w2, psi2, ds, tau, dq, dtau);
            }
            py::dict d = static_dict(res);
            d["t"] = tau;
            d["dq"] = dq;
            d["dt"] = dtau;
            return d;
        },
        "One arc-length step's Newton corrector (the core's static_newton with the spherical constraint as "
        "border) from the state (updated in place): path (m0, m1, l0, l1) gives mdot = m0 + m1 t [kg/s] and the "
        "load factor l0 + l1 t; the constraint |W dq|^2 + psi2 dt^2 = ds^2 (w2 = W^2) on the increment (dq, dt) "
        "from the step's start, t the current path parameter. static_newton's dict with t, dq, dt updated.",
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("path"), py::arg("w2"), py::arg("psi2"),
        py::arg("ds"), py::arg("t"), py::arg("dq"), py::arg("dt"), py::arg("tol"), py::arg("length_scale"),
        py::arg("force_scale"), py::arg("max_iterations"));
    m.def(
        "steady_rotation",
        [](const Model& md, State& s, const LoadState& load, int hinge_node, int hinge_dof,
           const std::array<double, 3>& axis, double omega_guess, double length_scale, double tol,
           int max_iterations, int dense_below) {
            const SteadyRotationOptions opt = steady_options(tol, max_iterations, dense_below);
            SteadyRotationOutcome out;
            {
                py::gil_scoped_release release;
                out = steady_rotation(md, s, load, hinge_node, hinge_dof, Vec3<double>{{axis[0], axis[1], axis[2]}},
                                      omega_guess, length_scale, opt);
            }
            return steady_dict(out);
        },
        "Steady rotation of an element model about its hinge (hinge_node, its one reduced coordinate hinge_dof, "
        "the unit axis) at the load's mass flow: one static_newton with omega as border from the state (updated "
        "in place: the last iterate with the rotation's rates); omega_guess NaN: the rigid balance of the "
        "starting shape. The continuation in the flow is the caller's. A dict: converged, singular, omega "
        "[rad/s], iterations, residual [N].",
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("hinge_node"), py::arg("hinge_dof"),
        py::arg("axis"), py::arg("omega_guess"), py::arg("length_scale"),
        py::arg("tol"), py::arg("max_iterations"), py::arg("dense_below"));
    m.def(
        "coupled_steady_rotation",
        [](const Model& md, State& s, const LoadState& load, const MultibodySystemCore& bodies, const Arr& r,
           const Arr& R, const VecX& eta, const VecX& lam, const py::list& couplings, VecX coupling_lam,
           const Vec3d& point, const Vec3d& axis, int hinge_body, int hinge_dof, double omega_guess,
           double length_scale, double tol, int max_iterations, int dense_below) {
            MbState bs = to_state(bodies, r, R, eta, VecX::Zero(eta.size()), VecX::Zero(eta.size()), lam, 0.0);
            const std::vector<Coupling> cp = couplings_from(couplings);
            const RotationHinge h = rotation_hinge(point, axis, hinge_body, hinge_dof);
            const SteadyRotationOptions opt = steady_options(tol, max_iterations, dense_below);
            SteadyRotationOutcome out;
            {
                py::gil_scoped_release release;
                out = coupled_steady_rotation(md, s, load, bodies, bs, cp, coupling_lam, h, omega_guess, length_scale,
                                              opt);
            }
            py::dict d = steady_dict(out);
            d["bodies"] = from_state(bs);
            d["coupling_multipliers"] = coupling_lam;
            return d;
        },
        "Steady rotation of a coupled system about the axis through point (a body's ground hinge: hinge_body, "
        "else the element model's hinge coordinate hinge_dof) under the load's mass flow; the element state is "
        "updated in place. As steady_rotation's dict, with bodies (the body state) and coupling_multipliers.",
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("bodies"), py::arg("r"), py::arg("R"),
        py::arg("eta"), py::arg("lam"), py::arg("couplings"), py::arg("coupling_lam"), py::arg("point"),
        py::arg("axis"), py::arg("hinge_body"), py::arg("hinge_dof"), py::arg("omega_guess"), py::arg("length_scale"),
        py::arg("tol"), py::arg("max_iterations"), py::arg("dense_below"));
    m.def(
        "multibody_steady_rotation",
        [](const MultibodySystemCore& bodies, const Arr& r, const Arr& R, const VecX& eta, const VecX& lam,
           double mass_flow, const Vec3d& point, const Vec3d& axis, int hinge_body, double omega_guess,
           double tol, int max_iterations, int dense_below) {
            MbState bs = to_state(bodies, r, R, eta, VecX::Zero(eta.size()), VecX::Zero(eta.size()), lam, 0.0);
            const RotationHinge h = rotation_hinge(point, axis, hinge_body, -1);
            const SteadyRotationOptions opt = steady_options(tol, max_iterations, dense_below);
            SteadyRotationOutcome out;
            {
                py::gil_scoped_release release;
                out = multibody_steady_rotation(bodies, bs, mass_flow, h, omega_guess, opt);
            }
            py::dict d = steady_dict(out);
            d["bodies"] = from_state(bs);
            return d;
        },
        "Steady rotation of bodies about body hinge_body's ground hinge (axis through point) under the mass flow: "
        "as steady_rotation's dict, with bodies (the body state).",
        py::arg("bodies"), py::arg("r"), py::arg("R"), py::arg("eta"), py::arg("lam"), py::arg("mass_flow"),
        py::arg("point"), py::arg("axis"), py::arg("hinge_body"), py::arg("omega_guess"),
        py::arg("tol"), py::arg("max_iterations"), py::arg("dense_below"));
    m.def(
        "rotating_state",
        [](const Model& md, const Model& free, State& s, const LoadState& load, const std::array<double, 3>& centre,
           const std::array<double, 3>& axis, double omega, double length_scale, double tol, int max_iterations,
           double divergence) {
            RotatingStateOptions opt;
            opt.tol = tol;
            opt.max_iterations = max_iterations;
            opt.divergence = divergence;
            StaticNewtonResult out;
            {
                py::gil_scoped_release release;
                out = rotating_state(md, free, s, load, Vec3<double>{{centre[0], centre[1], centre[2]}},
                                     Vec3<double>{{axis[0], axis[1], axis[2]}}, omega, length_scale, opt);
            }
            return static_dict(out);
        },
        "The rotating state of an element model at the prescribed rate omega [rad/s] about the unit axis through "
        "the point centre [m] (seed 002's hub), by one core static_newton from the state (updated in place: the last "
        "iterate with the rotation's rates), the tangent through free (the model's unconstrained variant). A dict: "
        "converged, singular, diverged (a correction above divergence length scales), nonfinite, iterations, "
        "residual [N] (at the last iterate evaluated), correction (the last, [m, rad]).",
        py::arg("model"), py::arg("free"), py::arg("state"), py::arg("load"), py::arg("centre"), py::arg("axis"),
        py::arg("omega"), py::arg("length_scale"), py::arg("tol"), py::arg("max_iterations"), py::arg("divergence"));
    m.attr("DENSE_LU_BELOW") = kDenseLuBelow;
    m.def(
        "gravity_potential",
        [](const Model& md, const State& s, const LoadState& l) {
            check_state(md, s);
            return gravity_potential(md, s, l);
        },
        py::arg("model"), py::arg("state"), py::arg("load"), "Potential energy of gravity at the state [J].");
}
