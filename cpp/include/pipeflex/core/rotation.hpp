// Rotation parameterisation: nodal rotation R = exp(skew(phi)) * R_ref.
//
// phi [rad] is a rotation vector in global (spatial) components, measured from a
// per-node reference rotation R_ref that the analyses re-base (R_ref <- R, phi <- 0)
// whenever |phi| grows past pi, so rotations are unlimited. The spatial angular
// velocity is omega = T(phi) phi_dot with the left Jacobian
//     T(phi) = I + a(theta) skew(phi) + b(theta) skew(phi)^2,
//     a = (1 - cos theta)/theta^2,  b = (theta - sin theta)/theta^3,  theta = |phi|.
// Near theta = 0 the coefficients use their Taylor series in theta^2, so the functions
// are smooth (and differentiable by Dual numbers) at phi = 0.
#pragma once

#include "pipeflex/core/dual.hpp"
#include "pipeflex/core/small_matrix.hpp"

#include <cmath>

namespace pipeflex {

template <class S> Mat3<S> skew(const Vec3<S>& w) {
    Mat3<S> r;
    r(0, 0) = S(0.0); r(0, 1) = -w[2]; r(0, 2) = w[1];
    r(1, 0) = w[2]; r(1, 1) = S(0.0); r(1, 2) = -w[0];
    r(2, 0) = -w[1]; r(2, 1) = w[0]; r(2, 2) = S(0.0);
    return r;
}

// Coefficients s = sin(t)/t, a = (1-cos t)/t^2, b = (t-sin t)/t^3 as functions of t^2.
template <class S> void rotation_coefficients(const S& t2, S& s, S& a, S& b) {
    using std::cos; using std::sin; using std::sqrt;
    if (value_of(t2) < 1e-2) {
        // Series to t^8: truncation error below 1e-17 for t^2 < 1e-2 (by the constants'
        // reciprocals: multiplications, no division's latency)
        s = 1.0 - t2 * (1.0 / 6 - t2 * (1.0 / 120 - t2 * (1.0 / 5040 - t2 * (1.0 / 362880))));
        a = 0.5 - t2 * (1.0 / 24 - t2 * (1.0 / 720 - t2 * (1.0 / 40320 - t2 * (1.0 / 3628800))));
        b = 1.0 / 6 - t2 * (1.0 / 120 - t2 * (1.0 / 5040 - t2 * (1.0 / 362880 - t2 * (1.0 / 39916800))));
    } else {
        const S t = sqrt(t2);
        const S st = sin(t);
        s = st / t;
        a = (1.0 - cos(t)) / t2;
        b = (t - st) / (t2 * t);
    }
}


// I + c1 skew(phi) + c2 skew(phi)^2, the common form of exp and of its Jacobian, with
// skew(phi)^2 = phi phi^T - t2 I (t2 = |phi|^2): a third of the 3 x 3 product's operations
// (a residual evaluates two at every node).
template <class S> Mat3<S> rodrigues(const Vec3<S>& phi, const S& t2, const S& c1, const S& c2) {
    Mat3<S> r;
    const S d = 1.0 - c2 * t2;
    for (int i = 0; i < 3; ++i) {
        const S ci = c2 * phi[i];
        for (int j = 0; j < 3; ++j) r(i, j) = ci * phi[j];
        r(i, i) += d;
    }
    const Vec3<S> w = {{c1 * phi[0], c1 * phi[1], c1 * phi[2]}};
    r(0, 1) -= w[2]; r(0, 2) += w[1];
    r(1, 0) += w[2]; r(1, 2) -= w[0];
    r(2, 0) -= w[1]; r(2, 1) += w[0];
    return r;
}
template <class S> Mat3<S> rodrigues(const Vec3<S>& phi, const S& c1, const S& c2) {
    return rodrigues(phi, dot(phi, phi), c1, c2);
}

// exp(skew(phi)).
template <class S> Mat3<S> rotation_exp(const Vec3<S>& phi) {
    S s, a, b;
    rotation_coefficients(dot(phi, phi), s, a, b);
    return rodrigues(phi, s, a);
}

// Left Jacobian T(phi): omega = T(phi) phi_dot, delta_theta = T(phi) delta_phi.
template <class S> Mat3<S> rotation_jacobian(const Vec3<S>& phi) {
    S s, a, b;
    rotation_coefficients(dot(phi, phi), s, a, b);
    return rodrigues(phi, a, b);
}

// The coefficients' derivatives da = da/dt2, db = db/dt2 (t2 = |phi|^2) from their values s,
// a, b at t2 (rotation_coefficients): below t2 = 1e-2 the derivatives of the same series
// (Horner in t2), above da = (s - 2a) / (2 t2), db = (a - 3b) / (2 t2) (from da/dt = (s - 2a)/t,
// db/dt = (a - 3b)/t). Plain arithmetic in S: no nested Dual evaluation of the coefficients.
template <class S> void rotation_coefficient_rates(const S& t2, const S& s, const S& a, const S& b, S& da, S& db) {
    if (value_of(t2) < 1e-2) {
        da = -(1.0 / 24 - t2 * (1.0 / 360 - t2 * (1.0 / 13440 - t2 * (1.0 / 907200))));
        db = -(1.0 / 120 - t2 * (1.0 / 2520 - t2 * (1.0 / 120960 - t2 * (1.0 / 9979200))));
    } else {
        const S h = 0.5 / t2;
        da = (s - 2.0 * a) * h;
        db = (a - 3.0 * b) * h;
    }
}

// d/dt[T(phi)] phi_dot: the part of the angular velocity's rate omega_dot = T phi_ddot +
// d/dt[T] phi_dot that does not involve phi_ddot. With T = I + a W + b W^2 (a, b functions
// of t2 = |phi|^2, W = skew(phi)) and skew(phi_dot) phi_dot = 0:
//     d/dt[T] phi_dot = 2 (phi . phi_dot) (a' u + b' phi x u) + b phi_dot x u,  u = phi x phi_dot,
// with a' = da/dt2, b' = db/dt2 (rotation_coefficient_rates; a few cross products instead of
// T's 3 x 3 products in dual numbers: a residual evaluates it at every node of every
// element). s, a, b: the coefficients at t2 = |phi|^2.
template <class S>
Vec3<S> convective_angular_acceleration(const Vec3<S>& phi, const Vec3<S>& phid, const S& t2, const S& s, const S& a,
                                        const S& b) {
    S da, db;
    rotation_coefficient_rates(t2, s, a, b, da, db);
    const Vec3<S> u = cross(phi, phid), w = cross(phi, u), x = cross(phid, u);
    const S c = 2.0 * dot(phi, phid);
    Vec3<S> out;
    for (int i = 0; i < 3; ++i) out[i] = c * (da * u[i] + db * w[i]) + b * x[i];
    return out;
}

template <class S> Vec3<S> convective_angular_acceleration(const Vec3<S>& phi, const Vec3<S>& phid) {
    const S t2 = dot(phi, phi);
    S s, a, b;
    rotation_coefficients(t2, s, a, b);
    return convective_angular_acceleration(phi, phid, t2, s, a, b);
}

// What the elements at a node need of its rotation: R = exp(phi), T(phi), the spatial
// angular velocity w = T phid and acceleration al = T phidd + d/dt[T] phid. A residual
// evaluates it once per node for all the node's elements; re-basing a node keeps w and al.
template <class S> struct NodeMotion {
    Mat3<S> R, T;
    Vec3<S> w, al;
};

template <class S> NodeMotion<S> node_motion(const Vec3<S>& phi, const Vec3<S>& phid, const Vec3<S>& phidd) {
    // rotation_exp and rotation_jacobian with one evaluation of the coefficients (the same
    // operations, so the same bits)
    const S t2 = dot(phi, phi);
    S s, a, b;
    rotation_coefficients(t2, s, a, b);
    NodeMotion<S> m;
    m.R = rodrigues(phi, t2, s, a);
    m.T = rodrigues(phi, t2, a, b);
    m.w = m.T * phid;
    m.al = m.T * phidd;
    // quadratic in phi_dot: at rest its value and first derivatives vanish, so it is
    // skipped there
    if (value_of(phid[0]) != 0.0 || value_of(phid[1]) != 0.0 || value_of(phid[2]) != 0.0)
        m.al = m.al + convective_angular_acceleration(phi, phid, t2, s, a, b);
    return m;
}

// T(phi), its partial derivatives dT[k] = dT/dphi_k, the rate Td = sum_k dT[k] phid_k and
// its partial derivatives dTd[k] = dTd/dphi_k: what the analytic tangents of omega = T phid
// and of the convective term Td phid need. With W = skew(phi), T = I + a W + b W^2; the
// coefficients' first and second derivatives in t^2 = |phi|^2 come from one nested Dual
// evaluation of rotation_coefficients, the matrices from
//     skew(x) skew(y) + skew(y) skew(x) = x y^T + y x^T - 2 (x.y) I.
inline void rotation_jacobian_derivatives(const Vec3<double>& phi, const Vec3<double>& phid,
                                          Mat3<double>& T, Mat3<double> dT[3], Mat3<double>& Td,
                                          Mat3<double> dTd[3]) {
    using D1 = Dual<double, 1>;
    using D2 = Dual<D1, 1>;
    D2 t2(D1(dot(phi, phi), 0));
    t2.d[0] = D1(1.0);
    D2 s, a, b;
    rotation_coefficients(t2, s, a, b);
    const double a0 = a.v.v, a1 = a.v.d[0], a2 = a.d[0].d[0];
    const double b0 = b.v.v, b1 = b.v.d[0], b2 = b.d[0].d[0];
    T = rodrigues(phi, a0, b0);
    auto sym = [](const Vec3<double>& x, const Vec3<double>& y) {
        Mat3<double> r;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) r(i, j) = x[i] * y[j] + y[i] * x[j];
        const double xy = dot(x, y);
        for (int i = 0; i < 3; ++i) r(i, i) -= 2.0 * xy;
        return r;
    };
    const Mat3<double> W = skew(phi), V = skew(phid), VW = sym(phi, phid);
    Mat3<double> W2 = sym(phi, phi);
    for (int i = 0; i < 9; ++i) W2.c[i] *= 0.5;
    const double c = dot(phi, phid);
    for (int i = 0; i < 9; ++i) Td.c[i] = 2.0 * a1 * c * W.c[i] + a0 * V.c[i] + 2.0 * b1 * c * W2.c[i] + b0 * VW.c[i];
    for (int k = 0; k < 3; ++k) {
        Vec3<double> ek{};
        ek[k] = 1.0;
        const Mat3<double> Ek = skew(ek), EW = sym(ek, phi), EV = sym(ek, phid);
        const double cW = 4.0 * a2 * phi[k] * c + 2.0 * a1 * phid[k];
        const double cW2 = 4.0 * b2 * phi[k] * c + 2.0 * b1 * phid[k];
        for (int i = 0; i < 9; ++i) {
            dT[k].c[i] = 2.0 * a1 * phi[k] * W.c[i] + a0 * Ek.c[i] + 2.0 * b1 * phi[k] * W2.c[i] + b0 * EW.c[i];
            dTd[k].c[i] = cW * W.c[i] + 2.0 * a1 * c * Ek.c[i] + 2.0 * a1 * phi[k] * V.c[i] + cW2 * W2.c[i] +
                          2.0 * b1 * c * EW.c[i] + 2.0 * b1 * phi[k] * VW.c[i] + b0 * EV.c[i];
        }
    }
}

}  // namespace pipeflex
