// The linearised equations of any system (element model, bodies, both coupled).
#pragma once

#include "pipeflex/solvers/equations.hpp"

namespace pipeflex {

// About the state (z = 0, rates v and a, multipliers lam, time t) of the equations:
//     M dz'' + C dz' + K dz + C_q^T dlam = 0,   C_q dz = 0,
// with K = d(R + C_q^T lam)/dz (the constraint forces' geometric stiffness included),
// C = dR/dv and M = dR/da in the equations' own coordinates (n x n), and C_q (nc x n).
// Loads and gravity at their full value (load factor 1).
// K, C and M on one pattern (zeros included), C_q on its own, in compressed columns
// (Equations::tangents_csc); `pattern` (null: a temporary one) keeps their pattern for
// later calls on the same system (System::tangent_csc), which then only write values.
// With differences_step h > 0, also residual_differences(h) (tests).
struct LinearMatrices {
    int n = 0, nc = 0;
    CscMatrix K, C, M, Cq;
    Eigen::MatrixXd differences;
};
LinearMatrices linear_matrices(Equations& eq, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
                               const Eigen::VectorXd& lam, double t, double differences_step = 0.0,
                               TangentCsc* pattern = nullptr);

// Central differences (step h in z) of the residual [R + C_q^T lam; c] at the same state:
// the (n + nc) x n matrix that the tangent's [K; C_q] approximates (the tests' oracle for
// every element, body and joint). Leaves the equations set at z = 0.
Eigen::MatrixXd residual_differences(Equations& eq, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
                                     const Eigen::VectorXd& lam, double t, double h);

}  // namespace pipeflex
