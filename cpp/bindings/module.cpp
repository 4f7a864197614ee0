// pipeflex._core: thin bindings, one file per C++ area. Validation, defaults and
// documentation with units live in the Python package.
#include <pybind11/pybind11.h>

namespace py = pybind11;

void bind_elements(py::module_& m);
void bind_assembly(py::module_& m);
void bind_transient(py::module_& m);
void bind_ffrf(py::module_& m);
void bind_multibody(py::module_& m);

PYBIND11_MODULE(_core, m) {
    m.doc() = "pipeflex compiled core (element kernels and assembly)";
    bind_elements(m);
    bind_assembly(m);
    bind_transient(m);
    bind_ffrf(m);
    bind_multibody(m);
}
