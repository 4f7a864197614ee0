// The planar ANCF beam (ancf_beam2d's kernels) on the element interface: two ANCF nodes,
// of whose coordinates it uses x, y of the position and of the slope (the builder fixes
// z and z').
#pragma once

#include "pipeflex/assembly/element.hpp"
#include "pipeflex/elements/ancf_beam2d.hpp"

namespace pipeflex {

class AncfElement final : public Element {
public:
    AncfElement(int p, int q, const AncfElementData& d) : Element({p, q}), data(d) {}
    int p() const { return nodes()[0]; }
    int q() const { return nodes()[1]; }
    AncfElementData data;

    std::unique_ptr<Element> clone() const override { return std::make_unique<AncfElement>(*this); }
    const char* name() const override { return "ANCF element"; }
    bool accepts(NodeKind kind) const override { return kind == NodeKind::ancf; }
    void finalize(const Model& model) override;
    void kernel(const ElementInputs& in, const ElementOutputs& out) const override;
    void energies(const State& state, double* kinetic, double* elastic) const override;
    void add_gravity_potential(const State& state, const Vec3<double>& g, double* V) const override;
    double line_mass() const override { return data.mass; }
    bool damped() const override { return data.damped(); }
    void add_damping_power(const State& state, double* P) const override;
    const char* prestress_unavailable() const override;
    void prestress_stiffness(const State& state, const Eigen::VectorXd& dq, double* G) const override;
    bool in_co_rotating_frame() const override { return true; }

private:
    // its 8 element coordinates e from a 6-per-node vector of the model
    inline void gather8(const Eigen::VectorXd& x, double* e) const;
};

}  // namespace pipeflex
