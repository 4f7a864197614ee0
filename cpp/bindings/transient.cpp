#include "convert.hpp"
#include "outputs.hpp"
#include "pipeflex/core/format.hpp"
#include "pipeflex/solvers/coupled.hpp"
#include "pipeflex/solvers/element_equations.hpp"
#include "pipeflex/solvers/rigid_rotation.hpp"
#include "pipeflex/solvers/rotating_systems.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"
#include "pipeflex/solvers/system.hpp"
#include "pipeflex/solvers/transient.hpp"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <cmath>
#include <memory>
#include <string>

namespace py = pybind11;

using namespace pipeflex;

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
        .def_readwrite("mean", &TimeTable::mean)
        .def("at", &TimeTable::at, py::arg("time"), "The function's value at time [s].")
        .def("rate", &TimeTable::rate, py::arg("time"), "The function's derivative at time [s] (per second).");
    py::class_<TransientOptions>(m, "TransientOptions")
        .def(py::init<>())
        .def_readwrite("rtol", &TransientOptions::rtol)
        .def_readwrite("atol", &TransientOptions::atol)
        .def_readwrite("max_order", &TransientOptions::max_order)
        .def_readwrite("step", &TransientOptions::step)
        .def_readwrite("error_rate", &TransientOptions::error_rate)
        .def_readwrite("motion_rate", &TransientOptions::motion_rate)
        .def_readwrite("error_per_step", &TransientOptions::error_per_step)
        .def_readwrite("rotation_error_length", &TransientOptions::rotation_error_length)
        .def_readwrite("steps", &TransientOptions::steps)
        .def_readwrite("min_step", &TransientOptions::min_step)
        .def_readwrite("rho_inf", &TransientOptions::rho_inf)
        .def_readwrite("newton_tol", &TransientOptions::newton_tol)
        .def_readwrite("max_newton", &TransientOptions::max_newton)
        .def_readwrite("max_steps", &TransientOptions::max_steps)
        .def_readwrite("rebase_angle", &TransientOptions::rebase_angle)
        .def_readwrite("length_scale", &TransientOptions::length_scale)
        .def_readwrite("divergence_limit", &TransientOptions::divergence_limit)
        .def_readwrite("work", &TransientOptions::work);
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
    m.def(
        "rigid_rotation_rates",
        [](const Model& md, State& s, const std::array<double, 3>& centre, const std::array<double, 3>& axis,
           double omega) {
            check_state(md, s);
            rigid_rotation_rates(md, s, Vec3<double>{{centre[0], centre[1], centre[2]}},
                                 Vec3<double>{{axis[0], axis[1], axis[2]}}, omega);
        },
        "Sets state.v and state.a to the rates of the rigid rotation of the element model at rate omega [rad/s] "
        "about the unit axis through the point centre [m], at phi = 0 (positions and ANCF slopes turning with "
        "omega axis x, rotation vectors' rate omega axis): the kinematics of rotating_state's equations.",
        py::arg("model"), py::arg("state"), py::arg("centre"), py::arg("axis"), py::arg("omega"));
    m.def(
        "rigid_rotation_operators",
        [](const Model& md, const Model& free, const std::array<double, 3>& axis) {
            RigidRotationOperators o = rigid_rotation_operators(md, free, Vec3<double>{{axis[0], axis[1], axis[2]}});
            auto csc = [](CscMatrix& x) {
                return py::make_tuple(owned_array(std::move(x.values)), owned_array(std::move(x.row_index)),
                                      owned_array(std::move(x.col_ptr)), py::make_tuple(x.rows, x.cols));
            };
            return py::make_tuple(csc(o.T_rel), csc(o.A), csc(o.B));
        },
        "The rigid rotation's rate operators about the unit axis on the coordinates of free (the model's "
        "unconstrained variant), block diagonal by node: (T_rel, A, B), each (data, indices, indptr, shape) in "
        "compressed columns. T_rel = pinv(T_f) T: the model's coordinates in free's; A and B: the rates' "
        "derivatives per unit omega and omega^2 at phi = 0 (S and S^2 for positions and ANCF slopes, S/2 and "
        "S^2/6 for rotation vectors, S = skew(axis)). ValueError if free has other nodes or elements or the "
        "rotation turns its increments out of them (planar ANCF nodes about an axis other than z).",
        py::arg("model"), py::arg("free"), py::arg("axis"));
    m.attr("DENSE_LU_BELOW") = kDenseLuBelow;
    m.def(
        "gravity_potential",
        [](const Model& md, const State& s, const LoadState& l) {
            check_state(md, s);
            return gravity_potential(md, s, l);
        },
        py::arg("model"), py::arg("state"), py::arg("load"), "Potential energy of gravity at the state [J].");
}
