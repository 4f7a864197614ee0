// Conversions between the small fixed-size types of small_matrix.hpp and Eigen's, for the
// code that works in Eigen (the FFRF body, the multibody system, the bindings).
#pragma once

#include "pipeflex/core/small_matrix.hpp"

#include <Eigen/Core>

namespace pipeflex {

inline Vec3<double> to_vec3(const Eigen::Vector3d& a) { return {{a[0], a[1], a[2]}}; }
inline Eigen::Vector3d from_vec3(const Vec3<double>& a) { return {a[0], a[1], a[2]}; }

template <class M> Mat3<double> to_mat3(const Eigen::MatrixBase<M>& a) {
    Mat3<double> r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r(i, j) = a(i, j);
    return r;
}

// M: the Eigen 3x3 type to fill (the bindings hand numpy a row-major one).
template <class M = Eigen::Matrix3d> M from_mat3(const Mat3<double>& a) {
    M r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r(i, j) = a(i, j);
    return r;
}

}  // namespace pipeflex
