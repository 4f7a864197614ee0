#include "pipeflex/assembly/pipe_element.hpp"

#include "pipeflex/assembly/model.hpp"
#include "pipeflex/elements/hermite.hpp"

namespace pipeflex {

NodeFrames PipeElement::frames(const State& state) const { return {state.frames[p()], state.frames[q()]}; }

void PipeElement::finalize(const Model& model) {
    if (!(data.l0 > 0.0)) throw std::invalid_argument("pipe element length l0 must be > 0");
    // stress-free as built: eps^0 = eps(reference configuration)
    const NodeFrames identity{promote<double>(Mat3<double>{{1, 0, 0, 0, 1, 0, 0, 0, 1}}),
                              promote<double>(Mat3<double>{{1, 0, 0, 0, 1, 0, 0, 0, 1}})};
    double qe[12] = {};
    for (int k = 0; k < 3; ++k) {
        qe[k] = model.positions[p()][k];
        qe[6 + k] = model.positions[q()][k];
    }
    data.strain0 = {};
    pipe_strains(data, identity, qe, data.strain0.data());
    // the foundation's reference centre line: the built positions and the offsets' e_x
    // (the state's frames are rebased later, so the reference is kept here)
    data.found0 = {model.positions[p()], data.l0 * data.offset_p.col(0), model.positions[q()],
                   data.l0 * data.offset_q.col(0)};
}

void PipeElement::kernel(const ElementInputs& in, const ElementOutputs& out) const {
    const State& s = in.state;
    double qe[12], ve[12], ae[12];
    gather(s.q, qe);
    gather(s.v, ve);
    gather(s.a, ae);
    const NodeFrames fr = frames(s);
    if (out.nw == 0) {
        if (out.r == nullptr) return;
        if (in.motions != nullptr)
            pipe_residual(data, fr, in.load, qe, ve, ae, in.motions[p()], in.motions[q()], out.r);
        else
            pipe_residual(data, fr, in.load, qe, ve, ae, out.r);
        return;
    }
    // Several weight sets with derivatives (or the mixed Newton's stresses): the kernel
    // differentiates once for all (pipe_tangents); one set, or mass matrices only, take
    // pipe_tangent's shortcuts.
    bool derivatives = false;
    for (int i = 0; i < out.nw; ++i) derivatives = derivatives || out.weights[3 * i] != 0.0 || out.weights[3 * i + 1] != 0.0;
    if ((out.nw > 1 || out.geometric_stresses != nullptr) && derivatives) {
        pipe_tangents(data, fr, in.load, qe, ve, ae, out.nw, out.weights, out.r, out.J, out.geometric_stresses);
        return;
    }
    for (int i = 0; i < out.nw; ++i)
        pipe_tangent(data, fr, in.load, qe, ve, ae, out.weights[3 * i], out.weights[3 * i + 1], out.weights[3 * i + 2],
                     i == 0 ? out.r : nullptr, out.J[i]);
}

void PipeElement::energies(const State& state, double* kinetic, double* elastic) const {
    double qe[12], ve[12];
    gather(state.q, qe);
    gather(state.v, ve);
    pipe_energies(data, frames(state), qe, ve, kinetic, elastic);
}

void PipeElement::add_gravity_potential(const State& s, const Vec3<double>& g, double* V) const {
    const double m = (data.pipe_mass + data.fluid_mass) * data.l0;
    const Mat3<double> Ep = s.rotation(p()) * data.offset_p;
    const Mat3<double> Eq = s.rotation(q()) * data.offset_q;
    const double l0 = data.l0;
    const Vec3<double> xp{{s.q[6 * p()], s.q[6 * p() + 1], s.q[6 * p() + 2]}};
    const Vec3<double> xq{{s.q[6 * q()], s.q[6 * q() + 1], s.q[6 * q() + 2]}};
    const Vec3<double> a[4] = {xp, l0 * Ep.col(0), xq, l0 * Eq.col(0)};
    for (int i = 0; i < 4; ++i) *V -= m * hermite::load[i] * dot(g, a[i]);
}

void PipeElement::add_fluid_power(const State& state, const LoadState& load, const NodeMotion<double>* motions,
                                  double* P) const {
    double qe[12], ve[12];
    gather(state.q, qe);
    gather(state.v, ve);
    if (motions != nullptr)
        *P += pipe_fluid_power(data, frames(state), load, qe, ve, motions[p()], motions[q()]);
    else
        *P += pipe_fluid_power(data, frames(state), load, qe, ve);
}

void PipeElement::add_damping_power(const State& state, double* P) const {
    double qe[12], ve[12];
    gather(state.q, qe);
    gather(state.v, ve);
    *P += pipe_damping_power(data, frames(state), qe, ve);
}

void PipeElement::predicted_stresses(const State& state, const Eigen::VectorXd& dq, double* sigma) const {
    double qe[12], de[12];
    gather(state.q, qe);
    gather(dq, de);
    pipe_predicted_stresses(data, frames(state), qe, de, sigma);
}

}  // namespace pipeflex
