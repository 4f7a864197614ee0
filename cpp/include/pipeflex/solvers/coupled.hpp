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
#include "pipeflex/solvers/system.hpp"
#include "pipeflex/solvers/transient.hpp"

#include <memory>
#include <vector>

namespace pipeflex {

struct Coupling {
    int element_node = 0;  // a frame node of the element model (node a of the joint)
    MbJoint joint;         // kind, body_b / node_b (the body node), C0, axis_b, perp_a
    // Or, if set, no joint but a spring-damper (AxialSpring or Bushing, nodes 0: the element
    // node, 1: the body node, finalized on spring_model at their reference positions; the
    // body node's reference orientation A0 in joint.C0): no constraint rows, its forces and
    // exact tangents (MbSpring's stand-in node for the body node).
    std::shared_ptr<const Element> spring;
    std::shared_ptr<const Model> spring_model;
    int rows(NodeKind element_kind) const {
        return spring ? 0 : element_kind == NodeKind::ancf ? 3 : joint.rows();
    }
};

// The coupled system (System) of the element model (its state updated in place by every
// analysis) and the bodies (their state owned: System::body_state) joined by the couplings
// (their multipliers owned: System::coupling_multipliers; coupling_lam: a guess, or empty).
std::unique_ptr<System> coupled_system(const Model& model, State& state, const LoadState& load,
                                       const MultibodySystemCore& bodies, const MbState& body_state,
                                       std::vector<Coupling> couplings, Eigen::VectorXd coupling_lam);

}  // namespace pipeflex
