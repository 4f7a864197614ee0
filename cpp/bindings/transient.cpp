#include "convert.hpp"
#include "pipeflex/solvers/transient.hpp"

#include <pybind11/functional.h>

namespace py = pybind11;
using namespace pipeflex;

namespace {

py::array_t<double> as_array(const std::vector<double>& v, std::vector<py::ssize_t> shape) {
    py::array_t<double> a(shape);
    std::copy(v.begin(), v.end(), a.mutable_data());
    return a;
}

using Integrator = TransientOutput (*)(const Model&, State&, const LoadState&, const TimeFunctions&,
                                       const std::vector<double>&, const TransientOptions&, const ProgressFn&);

py::dict run(Integrator f, const Model& model, State& state, const LoadState& load, const TimeTable& flow,
             const TimeTable& loads, const std::vector<double>& times, const TransientOptions& opt,
             py::object progress) {
    ProgressFn cb;
    if (!progress.is_none()) {
        cb = [progress](double t) {
            py::gil_scoped_acquire gil;
            progress(t);
        };
    }
    TransientOutput out;
    {
        py::gil_scoped_release release;
        out = f(model, state, load, TimeFunctions{flow, loads}, times, opt, cb);
    }
    const py::ssize_t nt = static_cast<py::ssize_t>(out.t.size()), N = model.n_nodes();
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
    d["steps"] = out.steps;
    d["newton_iterations"] = out.newton_iterations;
    d["jacobians"] = out.jacobians;
    d["rebases"] = out.rebases;
    d["failed_steps"] = out.failed_steps;
    d["convergence_failures"] = out.convergence_failures;
    return d;
}

}  // namespace

void bind_transient(py::module_& m) {
    py::class_<TimeTable>(m, "TimeTable")
        .def(py::init<>())
        .def_readwrite("t", &TimeTable::t)
        .def_readwrite("value", &TimeTable::value)
        .def_readwrite("omega", &TimeTable::omega)
        .def_readwrite("phase", &TimeTable::phase)
        .def("at", &TimeTable::at)
        .def("rate", &TimeTable::rate);
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
    m.def("integrate_ida", [](const Model& md, State& s, const LoadState& l, const TimeTable& f, const TimeTable& lf,
                              const std::vector<double>& t, const TransientOptions& o, py::object p) {
        return run(integrate_ida, md, s, l, f, lf, t, o, p);
    });
    m.def("integrate_generalized_alpha", [](const Model& md, State& s, const LoadState& l, const TimeTable& f,
                                            const TimeTable& lf, const std::vector<double>& t,
                                            const TransientOptions& o, py::object p) {
        return run(integrate_generalized_alpha, md, s, l, f, lf, t, o, p);
    });
    m.def("generalized_alpha_flow_map",
          [](const Model& md, State& s, const LoadState& l, const Eigen::VectorXd& z0, const Eigen::VectorXd& v0,
             double duration, int n_steps, bool sensitivity, const TransientOptions& o) {
              FlowMapOutput out;
              {
                  py::gil_scoped_release release;
                  out = generalized_alpha_flow_map(md, s, l, z0, v0, duration, n_steps, sensitivity, o);
              }
              py::dict d;
              d["z"] = as_array(out.z, {static_cast<py::ssize_t>(n_steps) + 1, md.n_dofs});
              d["v"] = out.v;
              d["a"] = out.a;
              d["a0"] = out.a0;
              d["monodromy"] = out.monodromy;
              d["steps"] = out.steps;
              d["newton_iterations"] = out.newton_iterations;
              d["jacobians"] = out.jacobians;
              return d;
          });
    m.def("gravity_potential", &gravity_potential);
}
