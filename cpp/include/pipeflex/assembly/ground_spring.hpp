// A linear spring-damper from one node (frame or ANCF) to the ground: massless, stiffness
// k = (kx, ky, kz) [N/m] and damping c = (cx, cy, cz) [N s/m] along the global axes,
// unstressed at the anchor X [m] (default: the node's reference position). With x the
// node's position and v its velocity:
//     r_x = K (x - X) + C v   (K = diag(k), C = diag(c)),  dr_x/dx = K, dr_x/dv = C;
//     elastic energy U = (x - X)^T K (x - X) / 2.
// At a frame node, optionally about the global axes: rotational stiffness
// k_phi = (k1, k2, k3) [N m/rad] on the rotation vector psi of R R0^T (R0 = I, the
// reference orientation; |psi| < pi), with U_phi = psi^T K_phi psi / 2, and rotational
// damping c_phi = (c1, c2, c3) [N m s/rad] on the spatial angular velocity w = T(phi) phi_dot
// (moment -C_phi w). On the rotation coordinates phi:
//     r_phi = dU_phi/dphi + T(phi)^T C_phi T(phi) phi_dot,
// with dU_phi/dphi = T(phi)^T T(psi)^-T K_phi psi and all its derivatives exact (nested
// Dual numbers through the logarithm of R); dr_phi/dphi_dot = T^T C_phi T. No M.
#pragma once

#include "pipeflex/assembly/element.hpp"

namespace pipeflex {

class GroundSpring final : public Element {
public:
    // k [N/m], c [N s/m], k_phi [N m/rad], c_phi [N m s/rad]: each component finite and
    // >= 0, else std::invalid_argument; anchor [m] (finite) if has_anchor, else the node's
    // reference position.
    GroundSpring(int node, const Vec3<double>& k, const Vec3<double>& c, bool has_anchor, const Vec3<double>& anchor,
                 const Vec3<double>& k_phi = {}, const Vec3<double>& c_phi = {});
    const Vec3<double>& stiffness() const { return k_; }
    const Vec3<double>& damping() const { return c_; }
    const Vec3<double>& anchor() const { return anchor_; }  // after finalize

    std::unique_ptr<Element> clone() const override { return std::make_unique<GroundSpring>(*this); }
    const char* name() const override { return "ground spring"; }
    // the rotational part needs a frame node's rotation
    bool accepts(NodeKind kind) const override { return kind == NodeKind::frame || !rotational_; }
    void finalize(const Model& model) override;
    void kernel(const ElementInputs& in, const ElementOutputs& out) const override;
    void energies(const State& state, double* kinetic, double* elastic) const override;
    void add_gravity_potential(const State&, const Vec3<double>&, double*) const override {}  // massless
    bool damped() const override;
    // sum c_i v_i^2 + (frame node) sum c_phi,i w_i^2, w = T(phi) phi_dot
    void add_damping_power(const State& state, double* P) const override;
    bool in_co_rotating_frame() const override { return !rotational_; }  // massless; a hub frame would turn R0

private:
    Vec3<double> k_, c_;   // [N/m], [N s/m]
    bool has_anchor_ = false;
    Vec3<double> anchor_;  // X [m]: given, or the reference position (finalize)
    Vec3<double> kr_, cr_;  // k_phi [N m/rad], c_phi [N m s/rad]
    bool rotational_ = false;  // any of them > 0
};

}  // namespace pipeflex
