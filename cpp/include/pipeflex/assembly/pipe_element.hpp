// The pipe element (pipe_beam3d's kernels) on the element interface: two frame nodes p
// and q (the flow goes from p to q).
#pragma once

#include "pipeflex/assembly/element.hpp"
#include "pipeflex/elements/pipe_beam3d.hpp"

namespace pipeflex {

class PipeElement final : public Element {
public:
    PipeElement(int p, int q, const PipeElementData& d) : Element({p, q}), data(d) {}
    int p() const { return nodes()[0]; }
    int q() const { return nodes()[1]; }
    // The section and its stress-free strains (eps^0: set by finalize from the reference
    // positions, so that the element is stress-free as built).
    PipeElementData data;

    std::unique_ptr<Element> clone() const override { return std::make_unique<PipeElement>(*this); }
    const char* name() const override { return "pipe element"; }
    bool accepts(NodeKind kind) const override { return kind == NodeKind::frame; }
    void finalize(const Model& model) override;
    void kernel(const ElementInputs& in, const ElementOutputs& out) const override;
    bool uses_node_motions() const override { return true; }
    void energies(const State& state, double* kinetic, double* elastic) const override;
    void add_gravity_potential(const State& state, const Vec3<double>& g, double* V) const override;
    double line_mass() const override { return data.pipe_mass + data.fluid_mass; }
    void add_fluid_power(const State& state, const LoadState& load, const NodeMotion<double>* motions,
                         double* P) const override;
    bool damped() const override { return data.kelvin_voigt() || data.c_ext != 0.0; }
    void add_damping_power(const State& state, double* P) const override;
    int n_stresses() const override { return 6; }
    void predicted_stresses(const State& state, const Eigen::VectorXd& dq, double* sigma) const override;
    const char* prestress_unavailable() const override {
        return "the small-deformation prestress stiffness is defined for ANCF Model A elements only; this model "
               "has pipe elements (use the steady-state linearisation)";
    }

private:
    NodeFrames frames(const State& state) const;
};

}  // namespace pipeflex
