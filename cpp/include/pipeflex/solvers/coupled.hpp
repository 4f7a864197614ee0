// An element model and a system of floating-frame bodies in one set of equations, joined
// by Lagrange-multiplier joints between element frame nodes and body nodes:
//     R_el(q_el, v_el, a_el) + C_el^T lambda_c = 0,
//     F_b(q_b, v_b, a_b) + C_b^T lambda_b + C_cb^T lambda_c = 0,
//     c_b(q_b) = 0,   c_c(q_el, q_b) = 0.
// Coordinates [z_el (the model's reduced coordinates); q_b (body after body)], constraints
// [the bodies' joints; the couplings]. The coupling equations are the body joints' (rigid,
// hinge, spherical), with the element node as node a.
#pragma once

#include "pipeflex/multibody/multibody.hpp"
#include "pipeflex/solvers/equations.hpp"
#include "pipeflex/solvers/linear_matrices.hpp"
#include "pipeflex/solvers/rotating_systems.hpp"
#include "pipeflex/solvers/transient.hpp"

#include <vector>

namespace pipeflex {

struct Coupling {
    int element_node = 0;  // a frame node of the element model (node a of the joint)
    MbJoint joint;         // kind, body_b / node_b (the body node), C0, axis_b, perp_a
};

struct CoupledOutput {
    TransientOutput elements;    // the element model at the output times (as the element integrators')
    std::vector<MbState> bodies; // the bodies' states at the output times
    std::vector<Eigen::VectorXd> coupling_multipliers;  // lambda_c at the output times
};

// Generalised-alpha from the element state and the body state (time times.front(); the
// body state's v, a, lam are replaced by consistent ones) through the output times.
// The mass flow drives both (the pipe elements and the bodies carrying fluid).
CoupledOutput integrate_coupled(const Model& model, State& state, const LoadState& load,
                                const TimeFunctions& functions, const MultibodySystemCore& bodies,
                                MbState& body_state, const std::vector<Coupling>& couplings,
                                const std::vector<double>& times, const TransientOptions& opt,
                                const ProgressFn& progress);

// Static equilibrium of a coupled system from the element state and the body state (both
// updated; the couplings' multipliers in coupling_lam, n rows, updated) under the mass flow
// mdot [kg/s] and the loads and gravity scaled by load_factor.
StaticNewtonResult coupled_static(const Model& model, State& state, const LoadState& load,
                                  const MultibodySystemCore& bodies, MbState& body_state,
                                  const std::vector<Coupling>& couplings, Eigen::VectorXd& coupling_lam,
                                  double load_factor, const TransientOptions& opt, double tol, int max_iterations);

// The linearised equations (linear_matrices) of the element model alone about the state
// (re-based in place), under the load's mass flow: the generic route (pf.linearize has a
// faster one-pass assembly); for tests against residual differences.
LinearMatrices element_linear_matrices(const Model& model, State& state, const LoadState& load,
                                       const TransientOptions& opt, double differences_step = 0.0);

// The linearised equations (linear_matrices) of a coupled system about the element state
// (re-based) and the body state with their multipliers, under the load's mass flow.
LinearMatrices coupled_linear_matrices(const Model& model, State& state, const LoadState& load,
                                       const MultibodySystemCore& bodies, const MbState& body_state,
                                       const std::vector<Coupling>& couplings, const Eigen::VectorXd& coupling_lam,
                                       const TransientOptions& opt, double differences_step = 0.0);

// Steady rotation of a coupled system about its hinge (a body's ground hinge, or the
// element model's) under the load's mass flow (rotating_systems.hpp: continuation in the
// flow, omega as the static Newton's border on the bordered KKT matrix), from the element
// state and the body state (both updated: the last iterate with the rotation's rates; the
// couplings' multipliers in coupling_lam, updated). length_scale [m]: the element model's.
SteadyRotationOutcome coupled_steady_rotation(const Model& model, State& state, const LoadState& load,
                                              const MultibodySystemCore& bodies, MbState& body_state,
                                              const std::vector<Coupling>& couplings, Eigen::VectorXd& coupling_lam,
                                              const RotationHinge& hinge, double omega_guess, double length_scale,
                                              const SteadyRotationOptions& opt);

}  // namespace pipeflex
