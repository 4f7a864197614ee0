// The rotation vector psi of a rotation matrix R = exp(skew(psi)), |psi| < pi, in a form
// (nested) Dual numbers differentiate: the rotational springs (ground spring, bushing)
// take their elastic energy psi^T K_phi psi / 2 and its exact gradient T(psi)^-T K_phi psi
// and Hessian from it.
#pragma once

#include "pipeflex/core/dual.hpp"
#include "pipeflex/core/small_matrix.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace pipeflex {

inline double rotation_atan2(double y, double x) { return std::atan2(y, x); }
template <class V, int N> Dual<V, N> rotation_atan2(const Dual<V, N>& y, const Dual<V, N>& x) {
    Dual<V, N> r;
    r.v = rotation_atan2(y.v, x.v);
    const V den = y.v * y.v + x.v * x.v;
    for (int i = 0; i < N; ++i) r.d[i] = (x.v * y.d[i] - y.v * x.d[i]) / den;
    return r;
}

// psi with R = exp(skew(psi)), |psi| < pi; std::domain_error(why()) within 1e-6 rad of pi,
// where it is not unique (why: a callable returning the message, called only then, so
// that a kernel does not allocate). With v = vee(R - R^T) / 2 = sin(theta) n and
// cos(theta) = (tr R - 1) / 2: psi = (theta / sin theta) v, the factor from its series in
// sin^2 near theta = 0.
template <class S, class Why> Vec3<S> rotation_log(const Mat3<S>& R, const Why& why) {
    using std::sqrt;
    const Vec3<S> v = {{0.5 * (R(2, 1) - R(1, 2)), 0.5 * (R(0, 2) - R(2, 0)), 0.5 * (R(1, 0) - R(0, 1))}};
    const S c = 0.5 * (R(0, 0) + R(1, 1) + R(2, 2) - 1.0);
    const S s2 = dot(v, v);
    S f;
    if (value_of(s2) < 1e-4 && value_of(c) > 0.0) {
        // asin(s) / s in s^2 = sin^2(theta): truncation below 1e-19 for s^2 < 1e-4
        f = 1.0 + s2 * (1.0 / 6 + s2 * (3.0 / 40 + s2 * (5.0 / 112 + s2 * (35.0 / 1152))));
    } else {
        const S s = sqrt(s2);
        const S theta = rotation_atan2(s, c);
        if (!(value_of(theta) < M_PI - 1e-6)) throw std::domain_error(why());
        f = theta / s;
    }
    return {{f * v[0], f * v[1], f * v[2]}};
}

}  // namespace pipeflex
