// Results of the core crossing to Python, shared by the bindings files.
#pragma once

#include "pipeflex/multibody/multibody.hpp"
#include "pipeflex/solvers/coupled.hpp"
#include "pipeflex/solvers/equations.hpp"
#include "pipeflex/solvers/linear_matrices.hpp"
#include "pipeflex/solvers/transient.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

namespace pipeflex {

using Arr = pybind11::array_t<double, pybind11::array::c_style | pybind11::array::forcecast>;

// Couplings of element nodes to body nodes from Python: (element node, kind 0 rigid /
// 1 hinge / 2 spherical, body, body node, C0, axis_b, perp0, perp1) tuples.
std::vector<Coupling> couplings_from(const pybind11::list& couplings);

// A body state from numpy arrays (sizes checked) and back: (r, R, eta, v, a, lam, t).
MbState to_state(const MultibodySystemCore& sys, const Arr& r, const Arr& R, const VecX& eta, const VecX& v,
                 const VecX& a, const VecX& lam, double t);
pybind11::tuple from_state(const MbState& s);

// FreeMotions as a dict: count, the force per body (n_bodies, 6; moments divided by the
// length scale: in N throughout), the largest reaction.
pybind11::dict free_dict(const MultibodySystemCore& sys, const FreeMotions& f);

// A static solve's outcome: converged, singular, iterations, residual [N], correction.
inline pybind11::dict static_dict(const StaticNewtonResult& r) {
    pybind11::dict d;
    d["converged"] = r.converged;
    d["singular"] = r.singular;
    d["diverged"] = r.diverged;
    d["nonfinite"] = r.nonfinite;
    d["iterations"] = r.iterations;
    d["residual"] = r.residual;
    d["correction"] = r.correction;
    d["negative_start"] = r.negative_start;
    d["negative_end"] = r.negative_end;
    return d;
}

// Linearised equations as {"n", "nc", "K", "C", "M", "Cq"}, each matrix a (rows, cols,
// values) tuple of numpy arrays (repeats to be summed).
inline pybind11::dict linear_dict(const LinearMatrices& m) {
    auto coo = [](const Triplets& t) {
        return pybind11::make_tuple(pybind11::array_t<int>(t.rows.size(), t.rows.data()),
                                    pybind11::array_t<int>(t.cols.size(), t.cols.data()),
                                    pybind11::array_t<double>(t.values.size(), t.values.data()));
    };
    pybind11::dict d;
    d["n"] = m.n;
    d["nc"] = m.nc;
    d["K"] = coo(m.K);
    d["C"] = coo(m.C);
    d["M"] = coo(m.M);
    d["Cq"] = coo(m.Cq);
    if (m.differences.size()) d["differences"] = m.differences;
    return d;
}

}  // namespace pipeflex
