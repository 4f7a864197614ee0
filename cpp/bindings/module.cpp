// pipeflex._core: thin bindings, one file per C++ area. Validation, defaults and
// documentation with units live in the Python package.
#include "pipeflex/core/interrupt.hpp"
#include "pipeflex/errors.hpp"

#include <pybind11/pybind11.h>

#include <cmath>

namespace py = pybind11;

void bind_elements(py::module_& m);
void bind_assembly(py::module_& m);
void bind_transient(py::module_& m);
void bind_ffrf(py::module_& m);
void bind_multibody(py::module_& m);
void bind_system(py::module_& m);
void bind_sensors(py::module_& m);

namespace {

// Raises pipeflex.errors.<name> with the failure's whereabouts as attributes (None: not
// known). Imported at translation time: pipeflex.errors is pure Python.
void raise_python(const char* name, const pipeflex::ConvergenceError& e) {
    const py::object cls = py::module_::import("pipeflex.errors").attr(name);
    const auto known = [](double x) -> py::object {
        if (std::isnan(x)) return py::none();
        return py::float_(x);
    };
    const auto& w = e.where;
    const py::object iteration = w.iteration < 0 ? py::object(py::none()) : py::object(py::int_(w.iteration));
    const py::object exc = cls(e.what(), py::arg("time") = known(w.time), py::arg("iteration") = iteration,
                               py::arg("residual") = known(w.residual), py::arg("load_factor") = known(w.load_factor),
                               py::arg("mass_flow") = known(w.mass_flow));
    PyErr_SetObject(cls.ptr(), exc.ptr());
}

// The core's loops poll this, some with the GIL released: take it for the check. A
// pending KeyboardInterrupt stays set for the translator below.
bool python_interrupted() {
    py::gil_scoped_acquire gil;
    return PyErr_CheckSignals() != 0;
}

}  // namespace

PYBIND11_MODULE(_core, m) {
    m.doc() = "pipeflex compiled core (element kernels and assembly)";
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const pipeflex::Interrupted&) {
            // PyErr_CheckSignals has set the KeyboardInterrupt (or the handler's error)
            if (!PyErr_Occurred()) PyErr_SetNone(PyExc_KeyboardInterrupt);
        } catch (const pipeflex::SingularMatrixError& e) {
            raise_python("SingularMatrixError", e);
        } catch (const pipeflex::ConvergenceError& e) {
            raise_python("ConvergenceError", e);
        }
    });
    pipeflex::set_interrupt_check(python_interrupted);
    bind_elements(m);
    bind_assembly(m);
    bind_transient(m);
    bind_ffrf(m);
    bind_multibody(m);
    bind_sensors(m);
    bind_system(m);
}
