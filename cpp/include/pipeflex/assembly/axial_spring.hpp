// A linear axial spring-damper between the positions of two nodes (frame or ANCF):
// massless, stiffness k [N/m], unstressed at the nodes' reference distance L0 [m], and a
// dashpot c [N s/m] in parallel. With d = x_b - x_a, l = |d|, e = d / l, the rate of
// extension l_dot = e . (v_b - v_a) [m/s] and the axial force T = k (l - L0) + c l_dot [N]:
//     r = [-T e, 0, T e, 0]   (on [x_a, (3 more), x_b, (3 more)]),
//     dr_b/dx_b = k e e^T + (T / l) P + (c / l) e (P dv)^T, P = I - e e^T, dv = v_b - v_a
//         (exact: the damping force's dependence on the positions through e),
//     dr_b/dv_b = c e e^T (and the signs of a, b), no M;
//     elastic energy U = k (l - L0)^2 / 2 (the dashpot stores none; it dissipates c l_dot^2).
// The example of docs/elements.md: an element type through the Element interface only.
#pragma once

#include "pipeflex/assembly/element.hpp"

namespace pipeflex {

class AxialSpring final : public Element {
public:
    // k [N/m], c [N s/m]: finite and >= 0, else std::invalid_argument.
    AxialSpring(int a, int b, double k, double c = 0.0);
    double stiffness() const { return k_; }
    double damping() const { return c_; }

    std::unique_ptr<Element> clone() const override { return std::make_unique<AxialSpring>(*this); }
    const char* name() const override { return "axial spring"; }
    bool accepts(NodeKind) const override { return true; }
    void finalize(const Model& model) override;
    void kernel(const ElementInputs& in, const ElementOutputs& out) const override;
    void energies(const State& state, double* kinetic, double* elastic) const override;
    void add_gravity_potential(const State&, const Vec3<double>&, double*) const override {}  // massless
    bool damped() const override { return c_ != 0.0; }
    void add_damping_power(const State& state, double* P) const override;  // c l_dot^2
    bool in_co_rotating_frame() const override { return true; }  // massless: no fictitious forces

private:
    double k_ = 0.0;   // k [N/m]
    double c_ = 0.0;   // c [N s/m]
    double l0_ = 0.0;  // L0 [m], set by finalize
    // d = x_b - x_a and its length l [m]
    double chord(const Eigen::VectorXd& q, Vec3<double>* d) const;
};

}  // namespace pipeflex
