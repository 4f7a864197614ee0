// Results of the core crossing to Python, shared by the bindings files.
#pragma once

#include "pipeflex/multibody/multibody.hpp"
#include "pipeflex/solvers/equations.hpp"
#include "pipeflex/solvers/transient.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

namespace pipeflex {

using Arr = pybind11::array_t<double, pybind11::array::c_style | pybind11::array::forcecast>;

// An element run's outputs: t, x, R, xd, omega, energies, work counters.
pybind11::dict transient_dict(const TransientOutput& out, pybind11::ssize_t n_nodes);

// A body state from numpy arrays (sizes checked) and back: (r, R, eta, v, a, lam, t).
MbState to_state(const MultibodySystemCore& sys, const Arr& r, const Arr& R, const VecX& eta, const VecX& v,
                 const VecX& a, const VecX& lam, double t);
pybind11::tuple from_state(const MbState& s);

// A static solve's outcome: converged, singular, iterations, residual [N], correction.
inline pybind11::dict static_dict(const StaticNewtonResult& r) {
    pybind11::dict d;
    d["converged"] = r.converged;
    d["singular"] = r.singular;
    d["diverged"] = r.diverged;
    d["iterations"] = r.iterations;
    d["residual"] = r.residual;
    d["correction"] = r.correction;
    return d;
}

}  // namespace pipeflex
