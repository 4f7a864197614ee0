// SUNDIALS IDA (variable-order, variable-step BDF with error control) on the Equations of
// any system: element models, floating-frame bodies with joints, both coupled.
//
// IDA takes index-1 and index-2 DAEs, not the index-3 equations of motion with joints, so
// it integrates their stabilised index-2 form (Gear, Gupta & Leimkuhler 1985), unknowns
// (z, v, lambda, mu):
//     z' = N(z) (v + C_q^T mu),   R(q, v, v', t) + C_q^T lambda = 0,
//     c(q, t) = 0,                C_q v + c_t = 0,
// N the chart's rate map (Equations::chart_rates: the identity for element nodes, T(z)^-1
// for a frame's spatial angular velocity), lambda and mu algebraic (excluded from the
// error test). Both the positions and the velocities satisfy their constraints, so
// neither drifts; mu is zero on the exact solution (C_q N^-1 z' = C_q v + C_q C_q^T mu
// makes C_q C_q^T mu = 0) and only absorbs the discretisation's share. Without
// constraints (nc = 0) it is the element model's ODE z' = v, R = 0.
//
// The Newton matrix is taken with the tangent's columns in the rates' increments
// (Equations::rate_increments: the left-trivialised tangent of a frame), dropping the
// derivatives of N(z) v and C_q v in z (O(h |v| / L) beside the kept terms); eliminating
// the position correction leaves the velocity's KKT system
//     [S, C_q^T; C_q, 0] [dv; c_j dlambda] = [c_j b2 - K (b1' + C_q^T dmu); b4],
//     C_q C_q^T dmu = c_j b3 - b4 - C_q b1',   S = K + c_j C + c_j^2 M,
// (b1' = N^-1 b1; b the residual's blocks), one sparse LU (FixedPatternLU) on the
// tangent's kept pattern (Equations::tangents_csc: K and S in one pass) and one of the
// small C_q C_q^T; without constraints that is one LU of n unknowns: a band LU of the
// 2n unknowns (z, v) costs of the order of (2 b)^2 per unknown for the half bandwidth b.
// Frames turned beyond the run's rebase_angle are re-based and IDA restarts from the
// same motion (IDAReInit).
#pragma once

#include "pipeflex/solvers/system.hpp"

#include <vector>

namespace pipeflex {

// IDA from the system's state (time times.front(), its rates; consistent accelerations and
// multipliers from initial_acceleration, the rates projected onto the velocity constraint)
// through the output times (interpolated by IDA between its steps); the end state stays in
// the system. The drive's options: rtol, atol, max_order, max_steps, rebase_angle.
// Counters as generalised-alpha's (Record::counters): failed_steps are IDA's error-test
// failures, convergence_failures its Newton failures.
Record integrate_ida(System& sys, const Drive& drive, const std::vector<double>& times, const ProgressFn& progress);

}  // namespace pipeflex
