// Conversions between numpy arrays and the core's small fixed-size types.
#pragma once

#include "pipeflex/core/small_matrix.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

namespace pipeflex::bindings {

namespace py = pybind11;
using RowMat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

inline Mat3<double> to_mat3(const RowMat3& a) {
    Mat3<double> r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r(i, j) = a(i, j);
    return r;
}
inline RowMat3 from_mat3(const Mat3<double>& a) {
    RowMat3 r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r(i, j) = a(i, j);
    return r;
}
inline Vec3<double> to_vec3(const Eigen::Vector3d& a) { return {{a[0], a[1], a[2]}}; }
inline Eigen::Vector3d from_vec3(const Vec3<double>& a) { return {a[0], a[1], a[2]}; }

}  // namespace pipeflex::bindings
