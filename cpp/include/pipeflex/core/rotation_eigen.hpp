// Eigen front ends of core/rotation.hpp for the code that works in Eigen 3-vectors and
// 3x3 matrices (the FFRF body, the multibody system). They convert and call the one
// implementation there, so the element and multibody parameterisations cannot drift apart.
#pragma once

#include "pipeflex/core/rotation.hpp"
#include "pipeflex/core/small_matrix_eigen.hpp"

namespace pipeflex {

// skew(w) x = w x x.
inline Eigen::Matrix3d skew(const Eigen::Vector3d& w) { return from_mat3(skew(to_vec3(w))); }

// The axial vector of the skew-symmetric part of D: vee_skew(skew(w)) = w.
inline Eigen::Vector3d vee_skew(const Eigen::Matrix3d& D) {
    return 0.5 * Eigen::Vector3d(D(2, 1) - D(1, 2), D(0, 2) - D(2, 0), D(1, 0) - D(0, 1));
}

// exp(skew(phi)).
inline Eigen::Matrix3d rotation_exp(const Eigen::Vector3d& phi) { return from_mat3(rotation_exp(to_vec3(phi))); }

// Left Jacobian T(phi).
inline Eigen::Matrix3d rotation_jacobian(const Eigen::Vector3d& phi) {
    return from_mat3(rotation_jacobian(to_vec3(phi)));
}

}  // namespace pipeflex
