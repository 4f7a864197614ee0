#include "pipeflex/assembly/axial_spring.hpp"

#include "pipeflex/assembly/model.hpp"

#include <cmath>
#include <string>

namespace pipeflex {

AxialSpring::AxialSpring(int a, int b, double k, double c) : Element({a, b}), k_(k), c_(c) {
    if (!(std::isfinite(k) && k >= 0.0))
        throw std::invalid_argument("axial spring: k must be a finite stiffness >= 0 [N/m], got " + std::to_string(k));
    if (!(std::isfinite(c) && c >= 0.0))
        throw std::invalid_argument("axial spring: c must be a finite damping coefficient >= 0 [N s/m], got " +
                                    std::to_string(c));
}

double AxialSpring::chord(const Eigen::VectorXd& q, Vec3<double>* d) const {
    const int a = nodes()[0], b = nodes()[1];
    for (int i = 0; i < 3; ++i) (*d)[i] = q[6 * b + i] - q[6 * a + i];
    return std::sqrt(dot(*d, *d));
}

void AxialSpring::finalize(const Model& model) {
    const int a = nodes()[0], b = nodes()[1];
    Vec3<double> d;
    for (int i = 0; i < 3; ++i) d[i] = model.positions[b][i] - model.positions[a][i];
    l0_ = std::sqrt(dot(d, d));
    if (!(l0_ > 0.0))
        throw std::invalid_argument("axial spring between nodes " + std::to_string(a) + " and " + std::to_string(b) +
                                    ": the nodes must be apart (its axis is the line between them)");
}

void AxialSpring::kernel(const ElementInputs& in, const ElementOutputs& out) const {
    if (out.nw == 0 && out.r == nullptr) return;
    Vec3<double> d;
    const double l = chord(in.state.q, &d);
    if (!(l > 0.0))
        throw std::domain_error("axial spring between nodes " + std::to_string(nodes()[0]) + " and " +
                                std::to_string(nodes()[1]) + ": the nodes coincide (no axis)");
    const Vec3<double> e = (1.0 / l) * d;
    // dv = v_b - v_a, its rate of extension l_dot = e . dv and its part across the axis P dv
    Vec3<double> dv{}, pdv{};
    double ldot = 0.0;
    if (c_ != 0.0) {
        const Eigen::VectorXd& v = in.state.v;
        const int a = nodes()[0], b = nodes()[1];
        for (int i = 0; i < 3; ++i) dv[i] = v[6 * b + i] - v[6 * a + i];
        ldot = dot(e, dv);
        for (int i = 0; i < 3; ++i) pdv[i] = dv[i] - ldot * e[i];
    }
    const double T = k_ * (l - l0_) + c_ * ldot;  // the axial force [N], tension positive
    if (out.r != nullptr)
        for (int i = 0; i < 3; ++i) {
            out.r[i] = -T * e[i];
            out.r[3 + i] = 0.0;
            out.r[6 + i] = T * e[i];
            out.r[9 + i] = 0.0;
        }
    for (int s = 0; s < out.nw; ++s) {
        const double wK = out.weights[3 * s], wC = out.weights[3 * s + 1];
        double* J = out.J[s];
        for (int i = 0; i < 144; ++i) J[i] = 0.0;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                const double eij = e[i] * e[j];
                const double kij = wK * (k_ * eij + T / l * ((i == j) - eij) + c_ / l * e[i] * pdv[j]) +
                                   wC * c_ * eij;
                J[12 * i + j] = kij;
                J[12 * (6 + i) + 6 + j] = kij;
                J[12 * i + 6 + j] = -kij;
                J[12 * (6 + i) + j] = -kij;
            }
    }
}

void AxialSpring::energies(const State& state, double* kinetic, double* elastic) const {
    Vec3<double> d;
    const double stretch = chord(state.q, &d) - l0_;
    *kinetic = 0.0;
    *elastic = 0.5 * k_ * stretch * stretch;
}

void AxialSpring::add_damping_power(const State& state, double* P) const {
    if (c_ == 0.0) return;
    Vec3<double> d;
    const double l = chord(state.q, &d);
    if (!(l > 0.0)) return;  // no axis: the kernel has refused the state
    const int a = nodes()[0], b = nodes()[1];
    double ldot = 0.0;
    for (int i = 0; i < 3; ++i) ldot += d[i] / l * (state.v[6 * b + i] - state.v[6 * a + i]);
    *P += c_ * ldot * ldot;
}

}  // namespace pipeflex
