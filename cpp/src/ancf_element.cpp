#include "pipeflex/assembly/ancf_element.hpp"

#include "pipeflex/assembly/model.hpp"
#include "pipeflex/elements/hermite.hpp"

#include <string>

namespace pipeflex {
namespace {

// The element's coordinates e (8) among its nodes' 6: slots 0, 1 (position) and 3, 4
// (slope) of each node.
constexpr int kSlot[4] = {0, 1, 3, 4};
int slot(int i) { return 6 * (i / 4) + kSlot[i % 4]; }

// An 8-vector or an 8x8 matrix into the 12 coordinates of the two nodes (zeros elsewhere).
void widen_vector(const double* r8, double* r12) {
    for (int i = 0; i < 12; ++i) r12[i] = 0.0;
    for (int i = 0; i < 8; ++i) r12[slot(i)] = r8[i];
}

void widen_matrix(const double* J8, double* J12) {
    for (int i = 0; i < 144; ++i) J12[i] = 0.0;
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j) J12[12 * slot(i) + slot(j)] = J8[8 * i + j];
}

}  // namespace

inline void AncfElement::gather8(const Eigen::VectorXd& x, double* e) const {
    const double* a = x.data() + 6 * p();
    const double* b = x.data() + 6 * q();
    for (int k = 0; k < 4; ++k) {
        e[k] = a[kSlot[k]];
        e[4 + k] = b[kSlot[k]];
    }
}

void AncfElement::finalize(const Model& model) {
    if (!(data.l > 0.0)) throw std::invalid_argument("ANCF element length l must be > 0");
    for (int i : nodes())
        if (model.bases[i].row(2).norm() != 0.0 || model.bases[i].row(5).norm() != 0.0)
            throw std::invalid_argument("ANCF node " + std::to_string(i) + " must have z and z' fixed (planar element)");
    // the foundation's reference coordinates: the built positions and slopes
    for (int k = 0; k < 2; ++k) {
        data.e0[k] = model.positions[p()][k];
        data.e0[2 + k] = model.slopes[p()][k];
        data.e0[4 + k] = model.positions[q()][k];
        data.e0[6 + k] = model.slopes[q()][k];
    }
}

void AncfElement::kernel(const ElementInputs& in, const ElementOutputs& out) const {
    if (out.nw == 0 && out.r == nullptr) return;
    const State& s = in.state;
    const LoadState& load = in.load;
    AncfFrame frame;
    frame.rate = load.frame_rate;
    frame.acceleration = load.frame_acceleration;
    frame.center[0] = load.frame_center[0];
    frame.center[1] = load.frame_center[1];
    const double g[2] = {load.gravity[0] * load.gravity_factor, load.gravity[1] * load.gravity_factor};
    double e[8], v8[8], a8[8], r8[8], J8[64];
    gather8(s.q, e);
    gather8(s.a, a8);
    gather8(s.v, v8);
    if (out.nw == 0) ancf_tangent(data, e, v8, a8, g, &frame, 0.0, 0.0, 0.0, r8, nullptr);
    for (int i = 0; i < out.nw; ++i) {
        const double* w = out.weights + 3 * i;
        ancf_tangent(data, e, v8, a8, g, &frame, w[0], w[1], w[2], i == 0 && out.r != nullptr ? r8 : nullptr, J8);
        widen_matrix(J8, out.J[i]);
    }
    if (out.r != nullptr) widen_vector(r8, out.r);
}

void AncfElement::energies(const State& state, double* kinetic, double* elastic) const {
    double e[8], v8[8];
    gather8(state.q, e);
    gather8(state.v, v8);
    ancf_energies(data, e, v8, kinetic, elastic);
}

void AncfElement::add_gravity_potential(const State& s, const Vec3<double>& g, double* V) const {
    // int rho A r dx = rho A l sum_i (int s_i) a_i, a = [r_A, l r_A', r_B, l r_B']
    const double m = data.mass * data.l, l = data.l;
    const double c[4] = {m * hermite::load[0], m * l * hermite::load[1], m * hermite::load[2], m * l * hermite::load[3]};
    const int at[4] = {6 * p(), 6 * p() + 3, 6 * q(), 6 * q() + 3};
    for (int i = 0; i < 4; ++i)
        for (int k = 0; k < 3; ++k) *V -= c[i] * g[k] * s.q[at[i] + k];
}

void AncfElement::add_damping_power(const State& state, double* P) const {
    double e[8], v8[8];
    gather8(state.q, e);
    gather8(state.v, v8);
    *P += ancf_damping_power(data, e, v8);
}

const char* AncfElement::prestress_unavailable() const {
    if (data.elastic == AncfElastic::model_a) return nullptr;
    return "the small-deformation prestress stiffness is defined for ANCF Model A elements only (Model 0 has no "
           "axial-bending coupling); use the steady-state linearisation";
}

void AncfElement::prestress_stiffness(const State& state, const Eigen::VectorXd& dq, double* G) const {
    double e[8], de[8], G8[64];
    gather8(state.q, e);
    gather8(dq, de);
    ancf_geometric_stiffness(data, e, de, G8);
    widen_matrix(G8, G);
}

}  // namespace pipeflex
