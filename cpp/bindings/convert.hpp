// numpy arrays <-> the core's small fixed-size types: 3x3 matrices cross as row-major
// (C-ordered) arrays; the conversions themselves are core/small_matrix_eigen.hpp's.
#pragma once

#include "pipeflex/core/small_matrix_eigen.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

namespace pipeflex::bindings {

namespace py = pybind11;
using RowMat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

}  // namespace pipeflex::bindings
