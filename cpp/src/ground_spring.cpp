#include "pipeflex/assembly/ground_spring.hpp"

#include "pipeflex/assembly/model.hpp"
#include "pipeflex/core/rotation.hpp"
#include "pipeflex/core/rotation_log.hpp"

#include <cmath>
#include <string>

namespace pipeflex {

namespace {

std::string turned_by_pi(int node) {
    return "ground spring at node " + std::to_string(node) +
           ": the node has turned by pi from its reference orientation, where the rotational spring's angle is "
           "not defined (it holds rotations below pi)";
}

}  // namespace

GroundSpring::GroundSpring(int node, const Vec3<double>& k, const Vec3<double>& c, bool has_anchor,
                           const Vec3<double>& anchor, const Vec3<double>& k_phi, const Vec3<double>& c_phi)
    : Element({node}), k_(k), c_(c), has_anchor_(has_anchor), anchor_(anchor), kr_(k_phi), cr_(c_phi) {
    auto check = [](const Vec3<double>& x, const char* what, const char* unit) {
        for (int i = 0; i < 3; ++i)
            if (!(std::isfinite(x[i]) && x[i] >= 0.0))
                throw std::invalid_argument(std::string("ground spring: ") + what + "[" + std::to_string(i) +
                                            "] must be finite and >= 0 [" + unit + "], got " + std::to_string(x[i]));
    };
    check(k, "stiffness", "N/m");
    check(c, "damping", "N s/m");
    check(k_phi, "rotational stiffness", "N m/rad");
    check(c_phi, "rotational damping", "N m s/rad");
    for (int i = 0; i < 3; ++i) {
        if (has_anchor && !std::isfinite(anchor[i]))
            throw std::invalid_argument("ground spring: anchor must be a finite point [m]");
        rotational_ = rotational_ || kr_[i] > 0.0 || cr_[i] > 0.0;
    }
}

void GroundSpring::finalize(const Model& model) {
    if (!has_anchor_) anchor_ = model.positions[nodes()[0]];
}

void GroundSpring::kernel(const ElementInputs& in, const ElementOutputs& out) const {
    const int n = nodes()[0];
    const Eigen::VectorXd &q = in.state.q, &v = in.state.v;
    double r[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    double H[9] = {};   // d r_phi / d phi
    double Cp[9] = {};  // d r_phi / d phi_dot
    for (int i = 0; i < 3; ++i) r[i] = k_[i] * (q[6 * n + i] - anchor_[i]) + c_[i] * v[6 * n + i];
    if (rotational_ && in.state.kinds[n] == NodeKind::frame) {
        const Vec3<double> phi = {{q[6 * n + 3], q[6 * n + 4], q[6 * n + 5]}};
        const Vec3<double> phid = {{v[6 * n + 3], v[6 * n + 4], v[6 * n + 5]}};
        const Mat3<double>& F = in.state.frames[n];
        if (kr_[0] > 0.0 || kr_[1] > 0.0 || kr_[2] > 0.0) {
            // U_phi(phi) in second-order Dual numbers: its gradient and Hessian
            using D1 = Dual<double, 3>;
            using D2 = Dual<D1, 3>;
            Vec3<D2> p;
            for (int i = 0; i < 3; ++i) {
                p[i] = D2(D1(phi[i], i));
                p[i].d[i] = D1(1.0);
            }
            const Vec3<D2> psi = rotation_log(rotation_exp(p) * promote<D2>(F), [n] { return turned_by_pi(n); });
            D2 U(0.0);
            for (int i = 0; i < 3; ++i) U += 0.5 * kr_[i] * psi[i] * psi[i];
            for (int i = 0; i < 3; ++i) {
                r[3 + i] += U.v.d[i];
                for (int j = 0; j < 3; ++j) H[3 * i + j] += U.d[i].d[j];
            }
        }
        if (cr_[0] > 0.0 || cr_[1] > 0.0 || cr_[2] > 0.0) {
            // T^T C_phi T phi_dot in Dual numbers on phi
            using D1 = Dual<double, 3>;
            Vec3<D1> p;
            for (int i = 0; i < 3; ++i) p[i] = D1(phi[i], i);
            const Mat3<D1> T = rotation_jacobian(p);
            Vec3<D1> cw = T * promote<D1>(phid);
            for (int i = 0; i < 3; ++i) cw[i] *= cr_[i];
            const Vec3<D1> g = tmul(T, cw);
            const Mat3<double> T0 = rotation_jacobian(phi);
            for (int i = 0; i < 3; ++i) {
                r[3 + i] += g[i].v;
                for (int j = 0; j < 3; ++j) {
                    H[3 * i + j] += g[i].d[j];
                    double s = 0.0;
                    for (int k = 0; k < 3; ++k) s += T0(k, i) * cr_[k] * T0(k, j);
                    Cp[3 * i + j] = s;
                }
            }
        }
    }
    if (out.r != nullptr)
        for (int i = 0; i < 6; ++i) out.r[i] = r[i];
    for (int s = 0; s < out.nw; ++s) {
        const double wK = out.weights[3 * s], wC = out.weights[3 * s + 1];
        double* J = out.J[s];
        for (int i = 0; i < 36; ++i) J[i] = 0.0;
        for (int i = 0; i < 3; ++i) {
            J[7 * i] = wK * k_[i] + wC * c_[i];
            for (int j = 0; j < 3; ++j) J[6 * (3 + i) + 3 + j] = wK * H[3 * i + j] + wC * Cp[3 * i + j];
        }
    }
}

void GroundSpring::energies(const State& state, double* kinetic, double* elastic) const {
    const int n = nodes()[0];
    *kinetic = 0.0;
    *elastic = 0.0;
    for (int i = 0; i < 3; ++i) {
        const double u = state.q[6 * n + i] - anchor_[i];
        *elastic += 0.5 * k_[i] * u * u;
    }
    if (rotational_ && state.kinds[n] == NodeKind::frame) {
        const Vec3<double> phi = {{state.q[6 * n + 3], state.q[6 * n + 4], state.q[6 * n + 5]}};
        const Vec3<double> psi = rotation_log(rotation_exp(phi) * state.frames[n], [n] { return turned_by_pi(n); });
        for (int i = 0; i < 3; ++i) *elastic += 0.5 * kr_[i] * psi[i] * psi[i];
    }
}

bool GroundSpring::damped() const {
    for (int i = 0; i < 3; ++i)
        if (c_[i] != 0.0 || cr_[i] != 0.0) return true;
    return false;
}

void GroundSpring::add_damping_power(const State& state, double* P) const {
    const int n = nodes()[0];
    const Eigen::VectorXd& v = state.v;
    for (int i = 0; i < 3; ++i) *P += c_[i] * v[6 * n + i] * v[6 * n + i];
    if (!rotational_ || state.kinds[n] != NodeKind::frame) return;
    // the kernel's T^T C_phi T phi_dot: its power is sum c_phi,i w_i^2
    const Vec3<double> phi = {{state.q[6 * n + 3], state.q[6 * n + 4], state.q[6 * n + 5]}};
    const Vec3<double> phid = {{v[6 * n + 3], v[6 * n + 4], v[6 * n + 5]}};
    const Vec3<double> w = rotation_jacobian(phi) * phid;
    for (int i = 0; i < 3; ++i) *P += cr_[i] * w[i] * w[i];
}

}  // namespace pipeflex
