// Bindings of the one system object (solvers/system.hpp) and of the analyses on it: each
// analysis bound once, for every formulation.
#include "convert.hpp"
#include "outputs.hpp"
#include "pipeflex/assembly/axial_spring.hpp"
#include "pipeflex/assembly/bushing.hpp"
#include "pipeflex/assembly/model.hpp"
#include "pipeflex/core/format.hpp"
#include "pipeflex/core/small_matrix_eigen.hpp"
#include "pipeflex/solvers/coupled.hpp"
#include "pipeflex/solvers/ida.hpp"
#include "pipeflex/solvers/system.hpp"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <chrono>
#include <optional>
#include <cmath>
#include <memory>
#include <string>

namespace py = pybind11;
using namespace pipeflex;

namespace {

// Largest output of one run [bytes], allocated up front by the caller's numpy arrays.
constexpr double kMaxOutputBytes = 2.0 * (1 << 30);

// Checks before any work: the output times are increasing and finite, the output fits in
// memory and, for generalised-alpha (fixed step, so its step count is known in advance),
// the steps to the last output are at most max_steps.
void check_run(const System& sys, const std::vector<double>& times, const TransientOptions& opt, bool fixed_step) {
    if (times.size() < 2) throw std::invalid_argument("times must hold at least 2 output times");
    for (std::size_t k = 0; k < times.size(); ++k) {
        if (!std::isfinite(times[k])) throw std::invalid_argument("times must be finite");
        if (k > 0 && !(times[k] > times[k - 1])) throw std::invalid_argument("times must be strictly increasing");
    }
    const double bytes = 8.0 * static_cast<double>(times.size()) * sys.record_size();
    if (bytes > kMaxOutputBytes)
        throw std::invalid_argument("n_outputs: " + std::to_string(times.size()) + " output times of " +
                                    fmt(sys.record_size()) + " values each need " + fmt(bytes / (1 << 30)) +
                                    " GiB; at most " + fmt(kMaxOutputBytes / (1 << 30)) +
                                    " GiB (fewer outputs, or split the run)");
    if (opt.max_steps < 1) throw std::invalid_argument("max_steps must be >= 1");
    if (!fixed_step) return;
    if (!(opt.step > 0.0) || !std::isfinite(opt.step)) throw std::invalid_argument("step must be > 0 and finite");
    if (!(opt.rho_inf >= 0.0 && opt.rho_inf <= 1.0)) throw std::invalid_argument("rho_inf must be in [0, 1]");
    if (!(opt.newton_tol > 0.0)) throw std::invalid_argument("newton_tol must be > 0");
    if (opt.max_newton < 1) throw std::invalid_argument("max_newton must be >= 1");
    // the integrator's equal steps per output interval: ceil(interval / step) each
    double steps = 0.0;
    for (std::size_t k = 1; k < times.size(); ++k) steps += std::ceil((times[k] - times[k - 1]) / opt.step - 1e-9);
    if (steps > static_cast<double>(opt.max_steps))
        throw std::invalid_argument("step = " + fmt(opt.step) + " s gives " + fmt(steps) + " steps from t = " +
                                    fmt(times.front()) + " s to " + fmt(times.back()) + " s; max_steps = " +
                                    std::to_string(opt.max_steps) + " (raise step or max_steps, or shorten the run)");
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

// A record as a dict: t (nt), each series (nt, *shape), the counters.
py::dict record_dict(const Record& r) {
    py::dict d;
    const py::ssize_t nt = static_cast<py::ssize_t>(r.t.size());
    py::array_t<double> t(nt);
    std::copy(r.t.begin(), r.t.end(), t.mutable_data());
    d["t"] = t;
    for (const auto& [name, s] : r.series) {
        std::vector<py::ssize_t> shape{nt};
        shape.insert(shape.end(), s.shape.begin(), s.shape.end());
        py::array_t<double> a(shape);
        if (static_cast<py::ssize_t>(s.data.size()) != a.size())
            throw std::logic_error("record: series " + name + " has " + std::to_string(s.data.size()) + " values");
        std::copy(s.data.begin(), s.data.end(), a.mutable_data());
        d[py::str(name)] = a;
    }
    for (const auto& [name, value] : r.counters) d[py::str(name)] = value;
    for (const auto& [name, value] : r.estimates) d[py::str(name)] = value;
    if (!r.steps.empty()) {
        py::array_t<double> h(static_cast<py::ssize_t>(r.steps.size()));
        std::copy(r.steps.begin(), r.steps.end(), h.mutable_data());
        d["step_sizes"] = h;
    }
    return d;
}

}  // namespace

// Couplings from Python: (element node, kind 0 rigid / 1 hinge / 2 spherical, body, body
// node, C0, axis_b, perp0, perp1) tuples.
std::vector<Coupling> pipeflex::couplings_from(const py::list& couplings) {
    std::vector<Coupling> cp;
    for (const py::handle& h : couplings) {
        const py::tuple c = py::reinterpret_borrow<py::tuple>(h);
        Coupling k;
        k.element_node = c[0].cast<int>();
        const int kind = c[1].cast<int>();
        if (kind == 3) {
            // (element node, 3, body, body node, k [N/m], c [N s/m], p0 element node, p0 body node [m])
            k.joint.body_b = c[2].cast<int>();
            k.joint.node_b = c[3].cast<int>();
            auto spring = std::make_unique<AxialSpring>(0, 1, c[4].cast<double>(), c[5].cast<double>());
            auto model = std::make_shared<Model>();
            model->positions = {to_vec3(c[6].cast<Vec3d>()), to_vec3(c[7].cast<Vec3d>())};
            model->kinds = {NodeKind::frame, NodeKind::frame};
            spring->finalize(*model);
            k.spring = std::move(spring);
            k.spring_model = std::move(model);
            cp.push_back(k);
            continue;
        }
        if (kind == 4) {
            // (element node, 4, body, body node, k (3) [N/m], c (3) [N s/m], k_phi (3) [N m/rad],
            //  c_phi (3) [N m s/rad], p0 element node, p0 body node [m], A0 body node)
            k.joint.body_b = c[2].cast<int>();
            k.joint.node_b = c[3].cast<int>();
            auto spring = std::make_unique<Bushing>(0, 1, to_vec3(c[4].cast<Vec3d>()), to_vec3(c[5].cast<Vec3d>()),
                                                    to_vec3(c[6].cast<Vec3d>()), to_vec3(c[7].cast<Vec3d>()));
            auto model = std::make_shared<Model>();
            model->positions = {to_vec3(c[8].cast<Vec3d>()), to_vec3(c[9].cast<Vec3d>())};
            model->kinds = {NodeKind::frame, NodeKind::frame};
            spring->finalize(*model);
            k.joint.C0 = c[10].cast<Mat3d>();
            k.spring = std::move(spring);
            k.spring_model = std::move(model);
            cp.push_back(k);
            continue;
        }
        if (kind < 0 || kind > 2)
            throw std::invalid_argument("coupling kind must be 0 (rigid), 1 (hinge), 2 (spherical), 3 (axial spring) "
                                        "or 4 (bushing)");
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

void bind_system(py::module_& m) {
    py::class_<System>(m, "System",
                       "One system of any formulation (element model, bodies, both coupled) with the state it works "
                       "on: what every analysis (static_equilibrium, linearize, integrate) takes.")
        .def_property_readonly("n_coordinates", &System::n_coordinates)
        .def_property_readonly("n_constraints", &System::n_constraints)
        .def_property_readonly("length_scale", &System::length_scale, "The model's size [m] (Newton's tests).")
        .def_property_readonly("length_coordinates", &System::length_coordinates,
                               "Per coordinate: 1 if it is a length [m] (positions, elastic amplitudes), else 0 "
                               "(rotations, slopes): the arc-length metric's weights.")
        .def_property_readonly(
            "body_state",
            [](System& s) -> py::object {
                MbState* b = s.body_state();
                return b == nullptr ? py::object(py::none()) : py::object(from_state(*b));
            },
            "The bodies' state (r, R, eta, v, a, lam, t), None without bodies.")
        .def_property_readonly(
            "element_state",
            [](System& s) -> py::object {
                const State* e = s.element_state();
                return e == nullptr ? py::object(py::none()) : py::cast(State(*e));
            },
            "A copy of the element model's state, None without elements.")
        .def_property_readonly(
            "coupling_multipliers",
            [](System& s) -> py::object {
                VecX* lam = s.coupling_multipliers();
                return lam == nullptr ? py::object(py::none()) : py::cast(*lam);
            },
            "The couplings' multipliers, None without couplings.")
        .def_property_readonly(
            "linear_pattern_builds", [](System& s) { return s.tangent_csc().builds; },
            "How many times linear_matrices built the system's tangent pattern (once, unless what the "
            "tangent holds changed: kept across calls).");
    m.def("element_system", &element_system, py::arg("model"), py::arg("state"), py::arg("load"),
          py::keep_alive<0, 1>(), py::keep_alive<0, 2>(),
          "The element model as a System; its analyses update the state in place.");
    m.def(
        "body_system",
        [](const MultibodySystemCore& bodies, const Arr& r, const Arr& R, const VecX& eta, const VecX& v,
           const VecX& a, const VecX& lam, double t) {
            return body_system(bodies, to_state(bodies, r, R, eta, v, a, lam, t));
        },
        py::arg("bodies"), py::arg("r"), py::arg("R"), py::arg("eta"), py::arg("v"), py::arg("a"), py::arg("lam"),
        py::arg("t"), py::keep_alive<0, 1>(), "Bodies and joints as a System, from their state (System.body_state).");
    m.def(
        "coupled_system",
        [](const Model& md, State& s, const LoadState& load, const MultibodySystemCore& bodies, const Arr& r,
           const Arr& R, const VecX& eta, const VecX& v, const VecX& a, const VecX& lam, double t,
           const py::list& couplings, const VecX& coupling_lam) {
            return coupled_system(md, s, load, bodies, to_state(bodies, r, R, eta, v, a, lam, t),
                                  couplings_from(couplings), coupling_lam);
        },
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("bodies"), py::arg("r"), py::arg("R"),
        py::arg("eta"), py::arg("v"), py::arg("a"), py::arg("lam"), py::arg("t"), py::arg("couplings"),
        py::arg("coupling_lam"), py::keep_alive<0, 1>(), py::keep_alive<0, 2>(), py::keep_alive<0, 4>(),
        "An element model and bodies joined by couplings ((element node, kind 0 rigid / 1 hinge / 2 spherical, "
        "body, body node, C0, axis_b, perp0, perp1) tuples, or (element node, 3, body, body node, k [N/m], "
        "c [N s/m], p0 of the element node, p0 of the body node [m]) for an axial spring-damper) as a System; "
        "the element state is updated in place.");
    m.def(
        "static_equilibrium",
        [](System& sys, double mass_flow, double load_factor, double tol, int max_iterations, double force_scale,
           bool inertia, bool mechanism) {
            StaticNewtonOptions opt;
            opt.tol = tol;
            opt.max_iterations = max_iterations;
            opt.force_scale = force_scale;
            opt.inertia = inertia;
            StaticNewtonResult res;
            {
                py::gil_scoped_release release;
                res = static_equilibrium(sys, mass_flow, load_factor, opt, TransientOptions(), mechanism);
            }
            py::dict d = static_dict(res);
            const MultibodySystemCore* bodies = sys.bodies();
            if (res.free.count >= 0 && bodies != nullptr) d["free"] = free_dict(*bodies, res.free);
            return d;
        },
        "Static equilibrium of the system (its state updated) by the core's one static_newton under the mass flow "
        "[kg/s] with the loads and gravity times load_factor; tol on the correction / length_scale or the residual / "
        "force_scale [N] (> 0); inertia: count the tangent's negative eigenvalues (negative_start, negative_end); "
        "mechanism: the joints leave a rigid motion free (bodies: the frames' free motions penalised; 'free' "
        "their free_motions dict at the end). A dict: converged, singular, diverged, nonfinite, iterations, "
        "residual [N], correction.",
        py::arg("system"), py::arg("mass_flow"), py::arg("load_factor"), py::arg("tol"), py::arg("max_iterations"),
        py::arg("force_scale") = 0.0, py::arg("inertia") = false, py::arg("mechanism") = false);
    m.def(
        "static_arc_newton",
        [](System& sys, const std::tuple<double, double, double, double>& path, const Eigen::VectorXd& w2, double psi2,
           double ds, double tau, Eigen::VectorXd dq, double dtau, double tol, int max_iterations,
           double force_scale, bool predict) {
            StaticNewtonOptions opt;
            opt.tol = tol;
            opt.max_iterations = max_iterations;
            opt.force_scale = force_scale;
            const ArcPath p{std::get<0>(path), std::get<1>(path), std::get<2>(path), std::get<3>(path)};
            StaticNewtonResult res;
            {
                py::gil_scoped_release release;
                res = static_arc_newton(sys, p, w2, psi2, ds, tau, dq, dtau, opt, TransientOptions(), predict);
            }
            py::dict d = static_dict(res);
            d["t"] = tau;
            d["dq"] = dq;
            d["dt"] = dtau;
            return d;
        },
        "One arc-length step's Newton corrector on the system (the core's static_newton with the spherical "
        "constraint as border): from the system's state (the step's start) moved by the predictor dq, the end state "
        "left in the system; path (m0, m1, l0, l1) gives mdot = m0 + m1 t [kg/s] and the load factor l0 + l1 t; "
        "the constraint |W dq|^2 + psi2 dt^2 = ds^2 (w2 = W^2) on the increment (dq, dt) from the step's start, t "
        "the predicted path parameter; tol on the correction / length_scale or the residual / force_scale [N] "
        "(> 0); predict false: the system's state is the predictor's already (dq the increment to it). "
        "static_newton's dict with t, dq, dt updated.",
        py::arg("system"), py::arg("path"), py::arg("w2"), py::arg("psi2"), py::arg("ds"), py::arg("t"), py::arg("dq"),
        py::arg("dt"), py::arg("tol"), py::arg("max_iterations"), py::arg("force_scale") = 0.0,
        py::arg("predict") = true);
    m.def(
        "static_arc_tangent",
        [](System& sys, const std::tuple<double, double, double, double>& path, double tau, const Eigen::VectorXd& w2,
           double psi2, const Eigen::VectorXd& previous_dq, double previous_dt) -> py::object {
            const ArcPath p{std::get<0>(path), std::get<1>(path), std::get<2>(path), std::get<3>(path)};
            Eigen::VectorXd v;
            double s = 0.0;
            bool ok;
            {
                py::gil_scoped_release release;
                ok = static_arc_tangent(sys, p, tau, w2, psi2, previous_dq, previous_dt, v, s, TransientOptions());
            }
            if (!ok) return py::none();
            return py::make_tuple(v, s);
        },
        "The unit tangent (dq/ds, dt/ds) of the equilibrium path at the system's state at path parameter t (path as "
        "static_arc_newton's), |W dq/ds|^2 + psi2 (dt/ds)^2 = 1, oriented along the previous tangent (previous_dq, "
        "previous_dt); dR/dt by central differences of step 1/2 (exact: R is quadratic in t). None if the "
        "bordered matrix is singular.",
        py::arg("system"), py::arg("path"), py::arg("t"), py::arg("w2"), py::arg("psi2"), py::arg("previous_dq"),
        py::arg("previous_dt"));
    m.def(
        "linear_matrices",
        [](System& sys, double mass_flow, double differences_step, double mass_flow_rate) {
            LinearMatrices lm;
            {
                py::gil_scoped_release release;
                lm = linearize(sys, mass_flow, TransientOptions(), differences_step, mass_flow_rate);
            }
            return linear_dict(std::move(lm));
        },
        "The linearised equations about the system's state (its rates and multipliers; an element model's frames "
        "re-based in place) under the mass flow [kg/s]: K, C, M (n x n, one pattern) and C_q (nc x n) as (data, "
        "indices, indptr) in compressed columns, on a pattern the system keeps for its later calls; with "
        "differences_step > 0 also the residual's central differences ('differences', tests); mass_flow_rate "
        "[kg/s^2] the flow's rate (an element model's fluid acceleration terms).",
        py::arg("system"), py::arg("mass_flow"), py::arg("differences_step") = 0.0, py::arg("mass_flow_rate") = 0.0);
    m.def(
        "integrate",
        [](System& sys, const TimeTable& mass_flow, const TimeTable& load_factor, const std::vector<double>& times,
           const TransientOptions& options, py::object progress, const std::string& integrator, SensorLog* sensors) {
            const bool ida = integrator == "ida";
            if (!ida && integrator != "generalized_alpha")
                throw std::invalid_argument("integrator must be 'generalized_alpha' or 'ida', got '" + integrator + "'");
            check_run(sys, times, options, !ida);
            Drive drive;
            drive.mass_flow = mass_flow;
            drive.load_factor = load_factor;
            drive.options = options;
            drive.sensors = sensors;
            const ProgressFn cb = progress_callback(progress);
            Record out;
            {
                py::gil_scoped_release release;
                out = ida ? integrate_ida(sys, drive, times, cb) : integrate(sys, drive, times, cb);
            }
            return record_dict(out);
        },
        "A transient run from the system's state (updated to the end) with the mass flow [kg/s] and the load factor "
        "as functions of time, output at times [s]; progress: None or a callable of the time [s]. A dict: t, the "
        "formulation's outputs per time (element models: x, R, xd, omega, energies and work; bodies: r, R, eta, v, "
        "a, lam, drift; coupled: both, the bodies' prefixed body_, and coupling_multipliers) and the counters steps, newton_iterations, "
        "jacobians, rebases, failed_steps, convergence_failures; sensors: a SensorLog recorded at the start and "
        "every accepted step (a terminal crossing ends the run at its step).",
        py::arg("system"), py::arg("mass_flow"), py::arg("load_factor"), py::arg("times"), py::arg("options"),
        py::arg("progress") = py::none(), py::arg("integrator") = "generalized_alpha",
        py::arg("sensors") = static_cast<SensorLog*>(nullptr));
    py::class_<FlowMapTangent, std::shared_ptr<FlowMapTangent>>(
        m, "FlowMapTangent", "The tangent-linear map d(z, v)_end / d(z0, v0) of a flow map, kept step by step.")
        .def(
            "apply",
            [](const FlowMapTangent& t, const Eigen::MatrixXd& directions) {
                py::gil_scoped_release release;
                return t.apply(directions);
            },
            py::arg("directions"), "(2n, p) directions [dz0; dv0] -> (2n, p) [dz; dv] at the end")
        .def_property_readonly("dimension", &FlowMapTangent::dimension)
        .def_property_readonly("nbytes", &FlowMapTangent::bytes);
    m.def(
        "flow_map",
        [](System& sys, double mass_flow, const Eigen::VectorXd& z0, const Eigen::VectorXd& v0, double duration,
           int n_steps, bool sensitivity, const TransientOptions& options, bool monodromy,
           std::optional<TimeTable> load_factor) {
            const int n = sys.n_coordinates();
            FlowMapOutput out;
            Eigen::MatrixXd Phi;
            {
                py::gil_scoped_release release;
                out = flow_map(sys, mass_flow, z0, v0, duration, n_steps, sensitivity, options,
                               load_factor ? *load_factor : TimeTable::constant(1.0));
                if (sensitivity && monodromy) Phi = out.tangent->apply(Eigen::MatrixXd::Identity(2 * n, 2 * n));
            }
            py::dict d;
            py::array_t<double> z({static_cast<py::ssize_t>(n_steps) + 1, static_cast<py::ssize_t>(n)});
            std::copy(out.z.begin(), out.z.end(), z.mutable_data());
            d["z"] = z;
            d["v"] = out.v;
            d["a"] = out.a;
            d["a0"] = out.a0;
            if (sensitivity) {
                d["tangent"] = out.tangent;
                if (monodromy) d["monodromy"] = Phi;
            }
            d["steps"] = out.steps;
            d["newton_iterations"] = out.newton_iterations;
            d["jacobians"] = out.jacobians;
            return d;
        },
        "The generalised-alpha flow map of the system (autonomous: the constant mass flow [kg/s], loads at their "
        "full value) over duration [s] in n_steps equal steps, in the chart of the system's state: from z0, v0 "
        "to z (every step), v, a at the end; with sensitivity its tangent-linear map ('tangent', FlowMapTangent) "
        "and, with monodromy, the monodromy matrix (its action on the identity). Floating frames are re-based "
        "every step and their z is the rotation's log relative to the state's frame (v: spatial angular "
        "velocities); element nodes stay in the fixed chart. load_factor: a TimeTable lambda(t) of the nodal loads, "
        "t from 0 at z0 (default None: 1, autonomous), e.g. a sine of period duration (a forced system).",
        py::arg("system"), py::arg("mass_flow"), py::arg("z0"), py::arg("v0"), py::arg("duration"), py::arg("n_steps"),
        py::arg("sensitivity"), py::arg("options"), py::arg("monodromy") = true, py::arg("load_factor") = py::none());
    m.def(
        "steady_rotation",
        [](System& sys, double mass_flow, const Vec3d& point, const Vec3d& axis, int hinge_body, int hinge_node,
           int hinge_dof, double omega_guess, double tol, int max_iterations, int dense_below) {
            RotationHinge h;
            h.point = point;
            h.axis = axis;
            h.body = hinge_body;
            h.node = hinge_node;
            h.element_dof = hinge_dof;
            SteadyRotationOptions opt;
            opt.tol = tol;
            opt.max_iterations = max_iterations;
            opt.dense_below = dense_below;
            SteadyRotationOutcome out;
            {
                py::gil_scoped_release release;
                out = steady_rotation(sys, h, mass_flow, omega_guess, opt);
            }
            py::dict d;
            d["converged"] = out.converged;
            d["singular"] = out.singular;
            d["omega"] = out.omega;
            d["iterations"] = out.iterations;
            d["residual"] = out.residual;
            return d;
        },
        "Steady rotation of the system (its state updated: the last iterate with the rotation's rates) about its "
        "hinge at the mass flow [kg/s]: the unit axis through point [m] of body hinge_body's ground hinge, or (-1) "
        "the element model's hinge coordinate hinge_dof (an element model alone: at node hinge_node); one "
        "static_newton with omega as its border, from omega_guess [rad/s] (NaN: the rigid balance of the starting "
        "shape). The continuation in the flow is the caller's. A dict: converged, singular, omega [rad/s], "
        "iterations, residual [N].",
        py::arg("system"), py::arg("mass_flow"), py::arg("point"), py::arg("axis"), py::arg("hinge_body"),
        py::arg("hinge_node"), py::arg("hinge_dof"), py::arg("omega_guess"), py::arg("tol"), py::arg("max_iterations"),
        py::arg("dense_below"));
    m.attr("MAX_OUTPUT_BYTES") = kMaxOutputBytes;  // pipeflex._checks.output_count checks it before allocating
}
