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

// A vector as a numpy array without a copy: the array owns it (moved into a capsule).
template <class T>
pybind11::array_t<T> owned_array(std::vector<T>&& v) {
    auto* held = new std::vector<T>(std::move(v));
    pybind11::capsule owner(held, [](void* p) { delete static_cast<std::vector<T>*>(p); });
    return pybind11::array_t<T>(static_cast<pybind11::ssize_t>(held->size()), held->data(), owner);
}

// Linearised equations as {"n", "nc", "K", "C", "M", "Cq"}, each matrix a (data, indices,
// indptr) tuple of numpy arrays in compressed columns (rows sorted, no repeats; K, C and M
// on one pattern, each with its own arrays), moved out of m.
inline pybind11::dict linear_dict(LinearMatrices&& m) {
    auto csc = [](CscMatrix& a) {
        return pybind11::make_tuple(owned_array(std::move(a.values)), owned_array(std::move(a.row_index)),
                                    owned_array(std::move(a.col_ptr)));
    };
    pybind11::dict d;
    d["n"] = m.n;
    d["nc"] = m.nc;
    d["K"] = csc(m.K);
    d["C"] = csc(m.C);
    d["M"] = csc(m.M);
    d["Cq"] = csc(m.Cq);
    if (m.differences.size()) d["differences"] = m.differences;
    return d;
}

}  // namespace pipeflex
