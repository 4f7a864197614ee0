// Sensors of a transient run (pipeflex.sensor builds them; sensors.hpp).
#include "outputs.hpp"
#include "pipeflex/assembly/model.hpp"
#include "pipeflex/core/format.hpp"
#include "pipeflex/core/user_function_error.hpp"
#include "pipeflex/solvers/sensors.hpp"

#include <pybind11/stl.h>

#include <cmath>
#include <memory>
#include <string>

namespace py = pybind11;

using namespace pipeflex;

namespace {

// What a custom sensor's function sees (pipeflex.sensor.custom): the parts' states as set,
// read while the call lasts (alive; each array a copy).
struct SensorView {
    const State* elements = nullptr;
    const MbState* bodies = nullptr;
    const VecX* couplings = nullptr;
    std::shared_ptr<bool> alive;
    void check() const {
        if (!*alive)
            throw std::runtime_error("a custom sensor's state is readable only during its call (copy what you keep)");
    }
    bool coupled() const { return elements != nullptr && bodies != nullptr; }
    [[noreturn]] void missing(const char* name) const {
        throw py::attribute_error(std::string("a custom sensor's state has no '") + name + "' here (" +
                                  (coupled() ? "a coupled system: state (the element model's q, v, a, frames), "
                                               "body_state (r, R, eta, v, a, lam), coupling_forces"
                                   : elements != nullptr ? "an element model: q, v, a, frames"
                                                         : "bodies: r, R, eta, v, a, lam") + ")");
    }
    const State& el(const char* name) const {
        check();
        if (elements == nullptr || bodies != nullptr) missing(name);
        return *elements;
    }
    const MbState& mb(const char* name) const {
        check();
        if (bodies == nullptr || elements != nullptr) missing(name);
        return *bodies;
    }
};

py::array_t<double> copy_of(const VecX& x) { return py::array_t<double>(x.size(), x.data()); }

// A Python callable fn(t, state) -> float or (width,) as the core's CustomSensor. The
// integrators release the GIL: each call takes it; the callable is held through a
// shared_ptr whose deleter takes the GIL. Errors as python_load's: fn's own as
// RuntimeError naming the sensor, the time, its type and message; a bad value ValueError.
std::shared_ptr<const CustomSensor> python_sensor(py::object fn, int width, const std::string& label) {
    std::shared_ptr<py::object> held(new py::object(std::move(fn)), [](py::object* p) {
        py::gil_scoped_acquire gil;
        delete p;
    });
    return std::make_shared<const CustomSensor>([held, width, label](double t, const SensorState& st, double* value) {
        py::gil_scoped_acquire gil;
        const auto alive = std::make_shared<bool>(true);
        py::object out;
        try {
            out = (*held)(t, SensorView{st.elements, st.bodies, st.coupling_multipliers, alive});
        } catch (py::error_already_set& e) {
            *alive = false;
            const std::string type = py::str(e.type().attr("__name__"));
            throw UserFunctionError("custom sensor '" + label + "' raised at t = " + fmt(t) + " s: " + type + ": " +
                                    std::string(py::str(e.value())));
        }
        *alive = false;
        const auto bad = [&](const std::string& why) {
            return UserFunctionValueError("custom sensor '" + label + "' at t = " + fmt(t) + " s: " + why);
        };
        if (width == 1 && (PyFloat_Check(out.ptr()) || PyLong_Check(out.ptr()))) {  // the common case, fast
            value[0] = out.cast<double>();
        } else {
            const auto a = Arr::ensure(out);
            if (!a || a.ndim() > 1 || a.size() != width)
                throw bad("must return " + (width == 1 ? std::string("a number") :
                                            std::to_string(width) + " values (its components)") +
                          ", got " + std::string(py::repr(out)));
            std::copy(a.data(), a.data() + width, value);
        }
        for (int k = 0; k < width; ++k)
            if (!std::isfinite(value[k])) throw bad("returned a value that is not finite: " + fmt(value[k]));
    });
}

}  // namespace

void bind_sensors(py::module_& m) {
    using RowMat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
    py::class_<SensorView>(m, "SensorState",
                           "What a custom sensor's function reads (pipeflex.sensor.custom), during its call only; "
                           "each attribute a copy. An element model: q, v, a (6 n_nodes,), frames (n_nodes, 3, 3) "
                           "as pipeflex.State; bodies: r, R, eta, v, a, lam as pipeflex.multibody.MultibodyState; a "
                           "coupled system: state and body_state (those two) and coupling_forces.")
        .def_property_readonly("q", [](const SensorView& s) { return copy_of(s.el("q").q); },
                               "(6 n_nodes,) the element nodes' coordinates [m, rad or -].")
        .def_property_readonly("frames",
                               [](const SensorView& s) {
                                   const State& st = s.el("frames");
                                   const auto n = static_cast<py::ssize_t>(st.frames.size());
                                   py::array_t<double> out({n, py::ssize_t(3), py::ssize_t(3)});
                                   for (py::ssize_t i = 0; i < n; ++i)
                                       std::copy(st.frames[i].c.begin(), st.frames[i].c.end(), out.mutable_data(i));
                                   return out;
                               },
                               "(n_nodes, 3, 3) the element nodes' reference rotations.")
        .def_property_readonly("v",
                               [](const SensorView& s) {
                                   s.check();
                                   return copy_of(s.bodies != nullptr && s.elements == nullptr ? s.mb("v").v
                                                                                                : s.el("v").v);
                               },
                               "the rates: (6 n_nodes,) of the element nodes, or the bodies' (N,) velocities.")
        .def_property_readonly("a",
                               [](const SensorView& s) {
                                   s.check();
                                   return copy_of(s.bodies != nullptr && s.elements == nullptr ? s.mb("a").a
                                                                                                : s.el("a").a);
                               },
                               "the accelerations (as v).")
        .def_property_readonly("r",
                               [](const SensorView& s) {
                                   const MbState& st = s.mb("r");
                                   const auto n = static_cast<py::ssize_t>(st.r.size());
                                   py::array_t<double> out({n, py::ssize_t(3)});
                                   for (py::ssize_t j = 0; j < n; ++j)
                                       std::copy(st.r[j].data(), st.r[j].data() + 3, out.mutable_data(j));
                                   return out;
                               },
                               "(n_bodies, 3) the frames' origins [m].")
        .def_property_readonly("R",
                               [](const SensorView& s) {
                                   const MbState& st = s.mb("R");
                                   const auto n = static_cast<py::ssize_t>(st.R.size());
                                   py::array_t<double> out({n, py::ssize_t(3), py::ssize_t(3)});
                                   for (py::ssize_t j = 0; j < n; ++j) {
                                       const RowMat3 R = st.R[j];
                                       std::copy(R.data(), R.data() + 9, out.mutable_data(j));
                                   }
                                   return out;
                               },
                               "(n_bodies, 3, 3) the frames' rotations.")
        .def_property_readonly("eta", [](const SensorView& s) { return copy_of(s.mb("eta").eta); },
                               "(N,) the bodies' elastic coordinates (frame entries zero).")
        .def_property_readonly("lam", [](const SensorView& s) { return copy_of(s.mb("lam").lam); },
                               "the bodies' joint multipliers [N, N m].")
        .def_property_readonly("state",
                               [](const SensorView& s) {
                                   s.check();
                                   if (!s.coupled()) s.missing("state");
                                   return SensorView{s.elements, nullptr, nullptr, s.alive};
                               },
                               "a coupled system's element part (q, v, a, frames).")
        .def_property_readonly("body_state",
                               [](const SensorView& s) {
                                   s.check();
                                   if (!s.coupled()) s.missing("body_state");
                                   return SensorView{nullptr, s.bodies, nullptr, s.alive};
                               },
                               "a coupled system's bodies (r, R, eta, v, a, lam).")
        .def_property_readonly("coupling_forces",
                               [](const SensorView& s) {
                                   s.check();
                                   if (s.couplings == nullptr) s.missing("coupling_forces");
                                   return copy_of(*s.couplings);
                               },
                               "a coupled system's coupling multipliers [N, N m].");
    py::class_<SensorLog>(m, "SensorLog",
                          "The sensors of a transient run (integrate's sensors=) and what they recorded at the start "
                          "and every accepted step.")
        .def(py::init<>())
        .def(
            "add",
            [](SensorLog& log, int kind, int index, double s, const std::array<double, 3>& axis, int rows, int part,
               int body, const std::array<double, 9>& frame) {
                if (kind < 0 || kind > static_cast<int>(SensorKind::custom))
                    throw std::invalid_argument("unknown sensor kind " + std::to_string(kind));
                if (part < 0 || part > static_cast<int>(SensorPart::couplings))
                    throw std::invalid_argument("part must be 0 (elements), 1 (bodies) or 2 (couplings), got " +
                                                std::to_string(part));
                SensorSpec spec;
                spec.kind = static_cast<SensorKind>(kind);
                spec.index = index;
                spec.s = s;
                spec.axis = axis;
                spec.rows = rows;
                spec.part = static_cast<SensorPart>(part);
                spec.body = body;
                spec.frame = frame;
                if (spec.width() < 1) throw std::invalid_argument("a sensor records at least one value");
                log.sensors.push_back(spec);
                return static_cast<int>(log.sensors.size()) - 1;
            },
            py::arg("kind"), py::arg("index"), py::arg("s") = 0.0, py::arg("axis") = std::array<double, 3>{},
            py::arg("rows") = 0, py::arg("part") = 0, py::arg("body") = 0,
            py::arg("frame") = std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1},
            "Adds a sensor (kind: the core's SensorKind number; index: node, element, spring or a joint's first "
            "constraint row; s in [0, 1] along the element; axis: a node angle's unit axis; rows: a joint's "
            "constraint rows; part: 0 the element model, 1 the bodies, 2 a coupled system's couplings; body: a body "
            "node's body; frame: a body node's reference orientation, row-major); returns its index.")
        .def(
            "add_custom",
            [](SensorLog& log, py::object fn, int width, const std::string& label) {
                if (!PyCallable_Check(fn.ptr())) throw std::invalid_argument("add_custom: fn must be callable");
                if (width < 1) throw std::invalid_argument("add_custom: width must be >= 1");
                SensorSpec spec;
                spec.kind = SensorKind::custom;
                spec.rows = width;
                spec.custom = python_sensor(std::move(fn), width, label);
                log.sensors.push_back(spec);
                return static_cast<int>(log.sensors.size()) - 1;
            },
            py::arg("fn"), py::arg("width"), py::arg("label"),
            "Adds a custom sensor: fn(t [s], state: a SensorState) -> a number or (width,) values, called at the "
            "start and every accepted step with the GIL taken; label names it in errors. Returns its index.")
        .def(
            "add_crossing",
            [](SensorLog& log, int sensor, int component, double level, int direction, bool terminal) {
                CrossingSpec c{sensor, component, level, direction, terminal};
                if (sensor < 0 || sensor >= static_cast<int>(log.sensors.size()))
                    throw std::invalid_argument("add_crossing: sensor " + std::to_string(sensor) + " not added");
                if (component < 0 || component >= log.sensors[sensor].width())
                    throw std::invalid_argument("add_crossing: component " + std::to_string(component) +
                                                " out of range");
                if (direction < -1 || direction > 1)
                    throw std::invalid_argument("add_crossing: direction must be -1, 0 or 1");
                log.crossings.push_back(c);
                return static_cast<int>(log.crossings.size()) - 1;
            },
            py::arg("sensor"), py::arg("component"), py::arg("level"), py::arg("direction"), py::arg("terminal"),
            "Adds a crossing of a sensor's component through level [its unit] (direction +1 up, -1 down, 0 both; "
            "terminal: end the run at the step that crosses); returns its index.")
        .def("width", [](const SensorLog& log, int i) { return log.sensors.at(static_cast<std::size_t>(i)).width(); },
             py::arg("sensor"), "The number of values a sensor records per time.")
        .def_property_readonly("t", [](const SensorLog& log) { return Arr(py::cast(log.t)); },
                               "(n,) the recorded times [s]: the start and every accepted step.")
        .def(
            "values",
            [](const SensorLog& log, int i) {
                const auto& v = log.values.at(static_cast<std::size_t>(i));
                const long w = log.sensors[static_cast<std::size_t>(i)].width();
                py::array_t<double> a({static_cast<py::ssize_t>(w ? v.size() / w : 0), static_cast<py::ssize_t>(w)});
                std::copy(v.begin(), v.end(), a.mutable_data());
                return a;
            },
            py::arg("sensor"), "(n, width) the values a sensor recorded.")
        .def(
            "crossings",
            [](const SensorLog& log, int j) {
                return py::make_tuple(Arr(py::cast(log.crossing_times.at(static_cast<std::size_t>(j)))),
                                      py::array_t<int>(py::cast(log.crossing_signs.at(static_cast<std::size_t>(j)))));
            },
            py::arg("crossing"), "(times [s], signs: +1 up, -1 down) of a crossing.")
        .def_readonly("stopped", &SensorLog::stopped)
        .def_readonly("stop_time", &SensorLog::stop_time);
}
