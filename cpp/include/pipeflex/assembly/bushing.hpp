// A linear 6-DOF spring-damper (bushing) between two nodes a and b: massless, with its
// translational and rotational stiffness and damping diagonal about the GLOBAL axes (they
// do not turn with the nodes: a simple, documented choice for small relative rotations of
// the connection). The nodes may coincide.
//
// Translation (frame or ANCF nodes), with u = x_b - x_a - d0 (d0 the nodes' reference
// offset X_b - X_a) and dv = v_b - v_a:
//     f = K u + C dv   (K = diag(k), C = diag(c)),   r_x_a = -f,  r_x_b = f,
//     elastic energy U_x = u^T K u / 2; no moment (the force acts at the nodes' positions).
// Rotation (both nodes frame nodes): psi the rotation vector of R_b R_a^T (global axes;
// R the nodes' rotations from their reference orientations, so psi = 0 in the reference
// configuration and under any equal rotation of both nodes), |psi| < pi, with
//     U_phi = psi^T K_phi psi / 2,   r_phi = dU_phi/dphi + damping,
// dU_phi/dphi_b = T(phi_b)^T T(psi)^-T K_phi psi (and the opposite moment on a, mapped by
// T(phi_a)^T), exact with all its derivatives through nested Dual numbers on the
// logarithm (rotation_log, as the ground spring's), and the damping moment on b
// -C_phi (w_b - w_a) (w = T(phi) phi_dot the spatial angular velocities), on a its
// opposite: r_phi_b += T_b^T C_phi (w_b - w_a), r_phi_a -= T_a^T C_phi (w_b - w_a).
// Tangents exact (wK, wC); no M.
#pragma once

#include "pipeflex/assembly/element.hpp"

namespace pipeflex {

class Bushing final : public Element {
public:
    // k [N/m], c [N s/m], k_phi [N m/rad], c_phi [N m s/rad]: each component finite and
    // >= 0, else std::invalid_argument; a != b.
    Bushing(int a, int b, const Vec3<double>& k, const Vec3<double>& c, const Vec3<double>& k_phi,
            const Vec3<double>& c_phi);
    const Vec3<double>& stiffness() const { return k_; }
    const Vec3<double>& damping() const { return c_; }
    const Vec3<double>& rotational_stiffness() const { return kr_; }
    const Vec3<double>& rotational_damping() const { return cr_; }
    const Vec3<double>& offset() const { return d0_; }  // d0 [m], after finalize

    std::unique_ptr<Element> clone() const override { return std::make_unique<Bushing>(*this); }
    const char* name() const override { return "bushing"; }
    // the rotational part needs both nodes' rotations
    bool accepts(NodeKind kind) const override { return kind == NodeKind::frame || !rotational_; }
    void finalize(const Model& model) override;
    void kernel(const ElementInputs& in, const ElementOutputs& out) const override;
    void energies(const State& state, double* kinetic, double* elastic) const override;
    void add_gravity_potential(const State&, const Vec3<double>&, double*) const override {}  // massless
    bool damped() const override;
    // dv^T C dv + (frame nodes) dw^T C_phi dw, dw = w_b - w_a
    void add_damping_power(const State& state, double* P) const override;
    bool in_co_rotating_frame() const override { return !rotational_; }  // massless

private:
    Vec3<double> k_, c_, kr_, cr_;  // [N/m], [N s/m], [N m/rad], [N m s/rad]
    Vec3<double> d0_{};             // X_b - X_a [m] (finalize)
    bool rotational_ = false;       // any of k_phi, c_phi > 0
    bool rotates(const State& state) const;
};

}  // namespace pipeflex
