// A linear axial spring between the positions of two nodes (frame or ANCF): massless,
// stiffness k [N/m], unstressed at the nodes' reference distance L0 [m]. With
// d = x_b - x_a, l = |d|, e = d / l and N = k (l - L0) [N]:
//     r = [-N e, 0, N e, 0]   (on [x_a, (3 more), x_b, (3 more)]),
//     dr/dx_b = k e e^T + (N / l)(I - e e^T) (and the signs of a, b), no C, no M;
//     elastic energy U = k (l - L0)^2 / 2.
// The example of docs/elements.md: an element type through the Element interface only.
#pragma once

#include "pipeflex/assembly/element.hpp"

namespace pipeflex {

class AxialSpring final : public Element {
public:
    // k [N/m]: finite and >= 0, else std::invalid_argument.
    AxialSpring(int a, int b, double k);
    double stiffness() const { return k_; }

    std::unique_ptr<Element> clone() const override { return std::make_unique<AxialSpring>(*this); }
    const char* name() const override { return "axial spring"; }
    bool accepts(NodeKind) const override { return true; }
    void finalize(const Model& model) override;
    void kernel(const ElementInputs& in, const ElementOutputs& out) const override;
    void energies(const State& state, double* kinetic, double* elastic) const override;
    void add_gravity_potential(const State&, const Vec3<double>&, double*) const override {}  // massless
    bool in_co_rotating_frame() const override { return true; }  // massless: no fictitious forces

private:
    double k_ = 0.0;   // k [N/m]
    double l0_ = 0.0;  // L0 [m], set by finalize
    // d = x_b - x_a and its length l [m]
    double chord(const Eigen::VectorXd& q, Vec3<double>* d) const;
};

}  // namespace pipeflex
