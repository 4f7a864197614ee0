#include "pipeflex/assembly/bushing.hpp"

#include "pipeflex/assembly/model.hpp"
#include "pipeflex/core/rotation.hpp"
#include "pipeflex/core/rotation_log.hpp"

#include <cmath>
#include <string>

namespace pipeflex {

namespace {

bool any(const Vec3<double>& x) { return x[0] > 0.0 || x[1] > 0.0 || x[2] > 0.0; }

Vec3<double> node_vec(const Eigen::VectorXd& x, int node, int first) {
    return {{x[6 * node + first], x[6 * node + first + 1], x[6 * node + first + 2]}};
}

}  // namespace

Bushing::Bushing(int a, int b, const Vec3<double>& k, const Vec3<double>& c, const Vec3<double>& k_phi,
                 const Vec3<double>& c_phi)
    : Element({a, b}), k_(k), c_(c), kr_(k_phi), cr_(c_phi) {
    auto check = [](const Vec3<double>& x, const char* what, const char* unit) {
        for (int i = 0; i < 3; ++i)
            if (!(std::isfinite(x[i]) && x[i] >= 0.0))
                throw std::invalid_argument(std::string("bushing: ") + what + "[" + std::to_string(i) +
                                            "] must be finite and >= 0 [" + unit + "], got " + std::to_string(x[i]));
    };
    check(k, "stiffness", "N/m");
    check(c, "damping", "N s/m");
    check(k_phi, "rotational stiffness", "N m/rad");
    check(c_phi, "rotational damping", "N m s/rad");
    if (a == b) throw std::invalid_argument("bushing: node_a and node_b must be two nodes, got " + std::to_string(a) +
                                            " twice");
    rotational_ = any(kr_) || any(cr_);
}

void Bushing::finalize(const Model& model) {
    const int a = nodes()[0], b = nodes()[1];
    for (int i = 0; i < 3; ++i) d0_[i] = model.positions[b][i] - model.positions[a][i];
}

bool Bushing::rotates(const State& state) const {
    return rotational_ && state.kinds[nodes()[0]] == NodeKind::frame && state.kinds[nodes()[1]] == NodeKind::frame;
}

void Bushing::kernel(const ElementInputs& in, const ElementOutputs& out) const {
    if (out.nw == 0 && out.r == nullptr) return;
    const int a = nodes()[0], b = nodes()[1];
    const Eigen::VectorXd &q = in.state.q, &v = in.state.v;
    double r[12] = {};
    double H[36] = {};   // d r_phi / d phi on (phi_a, phi_b)
    double Cp[36] = {};  // d r_phi / d phi_dot
    for (int i = 0; i < 3; ++i) {
        const double f = k_[i] * (q[6 * b + i] - q[6 * a + i] - d0_[i]) + c_[i] * (v[6 * b + i] - v[6 * a + i]);
        r[i] = -f;
        r[6 + i] = f;
    }
    if (rotates(in.state)) {
        const Vec3<double> pa = node_vec(q, a, 3), pb = node_vec(q, b, 3);
        const Mat3<double> Fab = in.state.frames[b] * transpose(in.state.frames[a]);
        if (any(kr_)) {
            // U_phi(phi_a, phi_b) in second-order Dual numbers: its gradient and Hessian
            using D1 = Dual<double, 6>;
            using D2 = Dual<D1, 6>;
            Vec3<D2> xa, xb;
            for (int i = 0; i < 3; ++i) {
                xa[i] = D2(D1(pa[i], i));
                xa[i].d[i] = D1(1.0);
                xb[i] = D2(D1(pb[i], 3 + i));
                xb[i].d[3 + i] = D1(1.0);
            }
            const Vec3<D2> psi = rotation_log(rotation_exp(xb) * promote<D2>(Fab) * transpose(rotation_exp(xa)), [&] {
                return "bushing between nodes " + std::to_string(a) + " and " + std::to_string(b) +
                       ": their relative rotation has reached pi, where the rotational spring's angle is not "
                       "defined (it holds relative rotations below pi)";
            });
            D2 U(0.0);
            for (int i = 0; i < 3; ++i) U += 0.5 * kr_[i] * psi[i] * psi[i];
            for (int i = 0; i < 6; ++i) {
                r[(i < 3 ? 3 : 6) + i] += U.v.d[i];
                for (int j = 0; j < 6; ++j) H[6 * i + j] += U.d[i].d[j];
            }
        }
        if (any(cr_)) {
            // g_b = T_b^T C_phi dw = -g_a (per T), dw = T_b phid_b - T_a phid_a, in Dual numbers on phi
            using D1 = Dual<double, 6>;
            Vec3<D1> xa, xb;
            for (int i = 0; i < 3; ++i) {
                xa[i] = D1(pa[i], i);
                xb[i] = D1(pb[i], 3 + i);
            }
            const Mat3<D1> Ta = rotation_jacobian(xa), Tb = rotation_jacobian(xb);
            Vec3<D1> m = Tb * promote<D1>(node_vec(v, b, 3)) - Ta * promote<D1>(node_vec(v, a, 3));
            for (int i = 0; i < 3; ++i) m[i] *= cr_[i];
            const Vec3<D1> ga = -tmul(Ta, m), gb = tmul(Tb, m);
            for (int i = 0; i < 3; ++i) {
                r[3 + i] += ga[i].v;
                r[9 + i] += gb[i].v;
                for (int j = 0; j < 6; ++j) {
                    H[6 * i + j] += ga[i].d[j];
                    H[6 * (3 + i) + j] += gb[i].d[j];
                }
            }
            const Mat3<double> T[2] = {rotation_jacobian(pa), rotation_jacobian(pb)};
            for (int I = 0; I < 2; ++I)
                for (int J = 0; J < 2; ++J)
                    for (int i = 0; i < 3; ++i)
                        for (int j = 0; j < 3; ++j) {
                            double s = 0.0;
                            for (int k = 0; k < 3; ++k) s += T[I](k, i) * cr_[k] * T[J](k, j);
                            Cp[6 * (3 * I + i) + 3 * J + j] = (I == J ? s : -s);
                        }
        }
    }
    if (out.r != nullptr)
        for (int i = 0; i < 12; ++i) out.r[i] = r[i];
    for (int s = 0; s < out.nw; ++s) {
        const double wK = out.weights[3 * s], wC = out.weights[3 * s + 1];
        double* J = out.J[s];
        for (int i = 0; i < 144; ++i) J[i] = 0.0;
        for (int I = 0; I < 2; ++I)
            for (int L = 0; L < 2; ++L) {
                const double sign = I == L ? 1.0 : -1.0;
                for (int i = 0; i < 3; ++i) {
                    J[12 * (6 * I + i) + 6 * L + i] = sign * (wK * k_[i] + wC * c_[i]);
                    for (int j = 0; j < 3; ++j) {
                        const int h = 6 * (3 * I + i) + 3 * L + j;
                        J[12 * (6 * I + 3 + i) + 6 * L + 3 + j] = wK * H[h] + wC * Cp[h];
                    }
                }
            }
    }
}

void Bushing::energies(const State& state, double* kinetic, double* elastic) const {
    const int a = nodes()[0], b = nodes()[1];
    *kinetic = 0.0;
    *elastic = 0.0;
    for (int i = 0; i < 3; ++i) {
        const double u = state.q[6 * b + i] - state.q[6 * a + i] - d0_[i];
        *elastic += 0.5 * k_[i] * u * u;
    }
    if (rotates(state) && any(kr_)) {
        const Mat3<double> Rb = rotation_exp(node_vec(state.q, b, 3)) * state.frames[b];
        const Mat3<double> Ra = rotation_exp(node_vec(state.q, a, 3)) * state.frames[a];
        const Vec3<double> psi = rotation_log(Rb * transpose(Ra), [&] {
            return "bushing between nodes " + std::to_string(a) + " and " + std::to_string(b) +
                   ": their relative rotation has reached pi (the rotational spring's angle is not defined)";
        });
        for (int i = 0; i < 3; ++i) *elastic += 0.5 * kr_[i] * psi[i] * psi[i];
    }
}

bool Bushing::damped() const { return any(c_) || any(cr_); }

void Bushing::add_damping_power(const State& state, double* P) const {
    const int a = nodes()[0], b = nodes()[1];
    const Eigen::VectorXd& v = state.v;
    for (int i = 0; i < 3; ++i) {
        const double dv = v[6 * b + i] - v[6 * a + i];
        *P += c_[i] * dv * dv;
    }
    if (!rotates(state) || !any(cr_)) return;
    const Vec3<double> dw = rotation_jacobian(node_vec(state.q, b, 3)) * node_vec(v, b, 3) -
                            rotation_jacobian(node_vec(state.q, a, 3)) * node_vec(v, a, 3);
    for (int i = 0; i < 3; ++i) *P += cr_[i] * dw[i] * dw[i];
}

}  // namespace pipeflex
