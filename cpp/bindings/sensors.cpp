// Sensors of a transient run (pipeflex.sensor builds them; sensors.hpp).
#include "outputs.hpp"
#include "pipeflex/solvers/sensors.hpp"

#include <pybind11/stl.h>

#include <string>

namespace py = pybind11;

using namespace pipeflex;

void bind_sensors(py::module_& m) {
    py::class_<SensorLog>(m, "SensorLog",
                          "The sensors of a transient run (integrate's sensors=) and what they recorded at the start "
                          "and every accepted step.")
        .def(py::init<>())
        .def(
            "add",
            [](SensorLog& log, int kind, int index, double s, const std::array<double, 3>& axis, int rows) {
                if (kind < 0 || kind > static_cast<int>(SensorKind::bushing))
                    throw std::invalid_argument("unknown sensor kind " + std::to_string(kind));
                SensorSpec spec;
                spec.kind = static_cast<SensorKind>(kind);
                spec.index = index;
                spec.s = s;
                spec.axis = axis;
                spec.rows = rows;
                if (spec.width() < 1) throw std::invalid_argument("a sensor records at least one value");
                log.sensors.push_back(spec);
                return static_cast<int>(log.sensors.size()) - 1;
            },
            py::arg("kind"), py::arg("index"), py::arg("s") = 0.0, py::arg("axis") = std::array<double, 3>{},
            py::arg("rows") = 0,
            "Adds a sensor (kind: the core's SensorKind number; index: node, element or a joint's first "
            "constraint row; s in [0, 1] along the element; axis: a node angle's unit axis; rows: a joint's "
            "constraint rows); returns its index.")
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
