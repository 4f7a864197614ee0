#include "pipeflex/elements/ancf_beam2d.hpp"

#include "pipeflex/core/dual.hpp"
#include "pipeflex/elements/hermite.hpp"

#include <cmath>

namespace pipeflex {
namespace {

// Integrals over xi in [0, 1] with the axial-strain weights N_X (X = A, M, B) that
// hermite.hpp does not tabulate, by its Gauss rule (the integrands are of degree <= 6, so
// exact). The Hermite functions s_i multiplying a slope are scaled by l in the element
// matrices.
struct Integrals {
    double axial[3][4][4];  // int N_X s_i' s_j'
    double quad[3][3];      // int N_X N_Y
};

const Integrals& integrals() {
    static const Integrals I = [] {
        Integrals r{};
        for (int g = 0; g < hermite::n_gauss; ++g) {
            const double xi = hermite::gauss_xi[g], wg = hermite::gauss_w[g];
            const hermite::Shape s = hermite::shape(xi);
            const double N[3] = {1 - 4 * xi + 3 * xi * xi, 6 * xi - 6 * xi * xi, -2 * xi + 3 * xi * xi};
            for (int i = 0; i < 4; ++i)
                for (int j = 0; j < 4; ++j)
                    for (int k = 0; k < 3; ++k) r.axial[k][i][j] += wg * N[k] * s.dN[i] * s.dN[j];
            for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b) r.quad[a][b] += wg * N[a] * N[b];
        }
        return r;
    }();
    return I;
}

constexpr int kSlope[4] = {0, 1, 0, 1};  // which Hermite functions multiply a slope

// 8x8 matrix c * int f_i f_j with f = [s1, l s2, s3, l s4] on both components.
void expand(const double (&m)[4][4], double l, double c, double* out) {
    const double sc[4] = {1.0, l, 1.0, l};
    for (int k = 0; k < 64; ++k) out[k] = 0.0;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            for (int comp = 0; comp < 2; ++comp) out[8 * (2 * i + comp) + 2 * j + comp] = c * sc[i] * sc[j] * m[i][j];
}

struct ModelAMatrices {
    double K[4][64];  // K_A, K_M, K_B, K_t
};

ModelAMatrices model_a_matrices(const AncfElementData& d) {
    ModelAMatrices m;
    for (int k = 0; k < 4; ++k) ancf_model_a_matrix(d, k, m.K[k]);
    return m;
}

template <class S>
void model_a_strains(const AncfElementData& d, const S* e, S* eps) {
    using std::sqrt;
    eps[0] = sqrt(e[2] * e[2] + e[3] * e[3]) - 1.0;
    eps[1] = sqrt((e[4] - e[0]) * (e[4] - e[0]) + (e[5] - e[1]) * (e[5] - e[1])) / d.l - 1.0;
    eps[2] = sqrt(e[6] * e[6] + e[7] * e[7]) - 1.0;
}

template <class S>
void model_a_forces(const AncfElementData& d, const ModelAMatrices& m, const S* e, S* Q) {
    S eps[3];
    model_a_strains(d, e, eps);
    for (int i = 0; i < 8; ++i) {
        S q = S(0.0);
        for (int j = 0; j < 8; ++j)
            q += (eps[0] * m.K[0][8 * i + j] + eps[1] * m.K[1][8 * i + j] + eps[2] * m.K[2][8 * i + j] +
                  S(m.K[3][8 * i + j])) * e[j];
        Q[i] = q;
    }
}

// Model 0 strain energy (see the header).
template <class S>
S model_0_energy(const AncfElementData& d, const S* e) {
    using std::sqrt;
    const double l = d.l;
    const S dx = e[4] - e[0], dy = e[5] - e[1];
    const S len = sqrt(dx * dx + dy * dy);
    const S cx = dx / len, cy = dy / len;
    // local coordinates of [r_A, r_A', r_B, r_B'] relative to r_A, minus the reference
    // [0, 0 | 1, 0 | l, 0 | 1, 0]; slopes scaled by l as in the Hermite basis
    S ux[4], uy[4];
    const S* v[4] = {nullptr, e + 2, nullptr, e + 6};
    ux[0] = S(0.0);
    uy[0] = S(0.0);
    ux[2] = len - l;
    uy[2] = S(0.0);
    for (int k : {1, 3}) {
        ux[k] = (cx * v[k][0] + cy * v[k][1] - 1.0) * l;
        uy[k] = (cx * v[k][1] - cy * v[k][0]) * l;
    }
    S U = S(0.0);
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            U += 0.5 * (d.EA / l * hermite::stretch[i][j] * ux[i] * ux[j] +
                        d.EI / (l * l * l) * hermite::bend[i][j] * uy[i] * uy[j]);
    return U;
}

void model_0_forces(const AncfElementData& d, const double* e, double* Q, double* K) {
    if (K == nullptr) {
        using D = Dual<double, 8>;
        D ed[8];
        for (int i = 0; i < 8; ++i) ed[i] = D(e[i], i);
        const D U = model_0_energy(d, ed);
        for (int i = 0; i < 8; ++i) Q[i] = U.d[i];
        return;
    }
    using D = Dual<double, 8>;
    using DD = Dual<D, 8>;
    DD ed[8];
    for (int i = 0; i < 8; ++i) ed[i] = DD(D(e[i], i), i);
    const DD U = model_0_energy(d, ed);
    for (int i = 0; i < 8; ++i) {
        Q[i] = U.d[i].v;
        for (int j = 0; j < 8; ++j) K[8 * i + j] = U.d[i].d[j];
    }
}

// Model 0's dissipation function R(e, e_dot) (see the header): U's quadratic form on the
// rates of the local displacements.
template <class S>
S model_0_dissipation(const AncfElementData& d, const S* e, const S* v) {
    using std::sqrt;
    const double l = d.l;
    const S dx = e[4] - e[0], dy = e[5] - e[1];
    const S dxt = v[4] - v[0], dyt = v[5] - v[1];
    const S len = sqrt(dx * dx + dy * dy);
    const S cx = dx / len, cy = dy / len;
    const S rate = cx * dxt + cy * dyt;  // d len / dt
    const S cxt = (dxt - cx * rate) / len, cyt = (dyt - cy * rate) / len;
    S ux[4], uy[4];
    ux[0] = uy[0] = uy[2] = S(0.0);
    ux[2] = rate;
    for (int k : {1, 3}) {
        const S* s = e + 2 * k;
        const S* st = v + 2 * k;
        ux[k] = (cxt * s[0] + cyt * s[1] + cx * st[0] + cy * st[1]) * l;
        uy[k] = (cxt * s[1] - cyt * s[0] + cx * st[1] - cy * st[0]) * l;
    }
    S R = S(0.0);
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            R += 0.5 * (d.eta_axial * d.EA / l * hermite::stretch[i][j] * ux[i] * ux[j] +
                        d.eta_bending * d.EI / (l * l * l) * hermite::bend[i][j] * uy[i] * uy[j]);
    return R;
}

// Model A's Kelvin-Voigt forces (see the header) on S, e and e_dot.
template <class S>
void model_a_damping(const AncfElementData& d, const ModelAMatrices& m, const S* e, const S* v, S* Q) {
    using std::sqrt;
    const S dx = e[4] - e[0], dy = e[5] - e[1];
    S rate[3];  // eps_dot_X
    rate[0] = (e[2] * v[2] + e[3] * v[3]) / sqrt(e[2] * e[2] + e[3] * e[3]);
    rate[1] = (dx * (v[4] - v[0]) + dy * (v[5] - v[1])) / (sqrt(dx * dx + dy * dy) * d.l);
    rate[2] = (e[6] * v[6] + e[7] * v[7]) / sqrt(e[6] * e[6] + e[7] * e[7]);
    for (int i = 0; i < 8; ++i) {
        S q = S(0.0);
        for (int j = 0; j < 8; ++j)
            q += d.eta_axial * (rate[0] * m.K[0][8 * i + j] + rate[1] * m.K[1][8 * i + j] + rate[2] * m.K[2][8 * i + j]) *
                     e[j] +
                 (d.eta_bending * m.K[3][8 * i + j]) * v[j];
        Q[i] = q;
    }
}

// The damping forces Q (8, added to) and their derivatives dQ/de (K) and dQ/de_dot (C)
// (8x8 each, overwritten), by forward AD in e and e_dot.
void damping_forces(const AncfElementData& d, const double* e, const double* v, double* Q, double* K, double* C) {
    for (int k = 0; k < 64; ++k) K[k] = C[k] = 0.0;
    if (d.eta_axial != 0.0 || d.eta_bending != 0.0) {
        if (d.elastic == AncfElastic::model_a) {
            using D = Dual<double, 16>;
            D ed[8], vd[8], Qd[8];
            for (int i = 0; i < 8; ++i) {
                ed[i] = D(e[i], i);
                vd[i] = D(v[i], 8 + i);
            }
            model_a_damping(d, model_a_matrices(d), ed, vd, Qd);
            for (int i = 0; i < 8; ++i) {
                Q[i] += Qd[i].v;
                for (int j = 0; j < 8; ++j) {
                    K[8 * i + j] += Qd[i].d[j];
                    C[8 * i + j] += Qd[i].d[8 + j];
                }
            }
        } else {
            // Q = dR/de_dot; its derivatives are R's second derivatives
            using D = Dual<double, 16>;
            using DD = Dual<D, 16>;
            DD ed[8], vd[8];
            for (int i = 0; i < 8; ++i) {
                ed[i] = DD(D(e[i], i), i);
                vd[i] = DD(D(v[i], 8 + i), 8 + i);
            }
            const DD R = model_0_dissipation(d, ed, vd);
            for (int i = 0; i < 8; ++i) {
                Q[i] += R.d[8 + i].v;
                for (int j = 0; j < 8; ++j) {
                    K[8 * i + j] += R.d[8 + i].d[j];
                    C[8 * i + j] += R.d[8 + i].d[8 + j];
                }
            }
        }
    }
    if (d.c_ext != 0.0) {
        double Mc[64];
        expand(hermite::mass, d.l, d.c_ext * d.l, Mc);
        for (int i = 0; i < 8; ++i)
            for (int j = 0; j < 8; ++j) {
                Q[i] += Mc[8 * i + j] * v[j];
                C[8 * i + j] += Mc[8 * i + j];
            }
    }
}

}  // namespace

void ancf_model_a_matrix(const AncfElementData& d, int which, double* out) {
    const Integrals& I = integrals();
    const double l = d.l;
    if (which >= 0 && which < 3) {
        expand(I.axial[which], l, d.EA / l, out);
    } else if (which == 3) {
        expand(hermite::bend, l, d.EI / (l * l * l), out);
    } else {
        expand(hermite::mass, l, d.mass * l, out);
        out[8 * 4 + 4] += d.tip_mass;
        out[8 * 5 + 5] += d.tip_mass;
    }
}

void ancf_tangent(const AncfElementData& d, const double* e, const double* v, const double* a, const double* gravity,
                  const AncfFrame* frame, double wK, double wC, double wM, double* r, double* J) {
    double M[64], Q[8], K[64];
    ancf_model_a_matrix(d, 4, M);
    const bool need_K = J != nullptr && wK != 0.0;
    if (d.elastic == AncfElastic::model_0) {
        model_0_forces(d, e, Q, need_K ? K : nullptr);
    } else {
        const ModelAMatrices m = model_a_matrices(d);
        model_a_forces<double>(d, m, e, Q);
        if (need_K) {
            using D = Dual<double, 8>;
            D ed[8], Qd[8];
            for (int i = 0; i < 8; ++i) ed[i] = D(e[i], i);
            model_a_forces<D>(d, m, ed, Qd);
            for (int i = 0; i < 8; ++i)
                for (int j = 0; j < 8; ++j) K[8 * i + j] = Qd[i].d[j];
        }
    }
    if (d.k_found != 0.0) {  // the foundation K_f (e - e0), an elastic force
        double Kf[64];
        expand(hermite::mass, d.l, d.k_found * d.l, Kf);
        for (int i = 0; i < 8; ++i)
            for (int j = 0; j < 8; ++j) {
                Q[i] += Kf[8 * i + j] * (e[j] - d.e0[j]);
                if (need_K) K[8 * i + j] += Kf[8 * i + j];
            }
    }
    // Frame terms: f = 2 w S e_dot + (w^2 S^2 + w_dot S)(e - c), multiplied by M.
    const bool turning = frame != nullptr && (frame->rate != 0.0 || frame->acceleration != 0.0);
    const double w = turning ? frame->rate : 0.0, wd = turning ? frame->acceleration : 0.0;
    auto S = [](const double* x, int i) { return i % 2 == 0 ? -x[i + 1] : x[i - 1]; };  // S on pairs
    if (r != nullptr) {
        double f[8] = {};
        if (turning) {
            double rel[8];
            for (int i = 0; i < 8; ++i) rel[i] = e[i] - ((i == 0 || i == 4) ? frame->center[0] : (i == 1 || i == 5) ? frame->center[1] : 0.0);
            for (int i = 0; i < 8; ++i) f[i] = 2.0 * w * S(v, i) - w * w * rel[i] + wd * S(rel, i);
        }
        for (int i = 0; i < 8; ++i) {
            double ma = 0.0;
            for (int j = 0; j < 8; ++j) ma += M[8 * i + j] * (a[j] + f[j]);
            r[i] = ma + Q[i];
            if (gravity != nullptr) {
                const int fn = i / 2;
                const double sc = kSlope[fn] ? d.l : 1.0;
                r[i] -= d.mass * d.l * sc * hermite::load[fn] * gravity[i % 2];
            }
        }
    }
    double Qd[8] = {}, Kd[64], Cd[64];
    if (d.damped()) {
        damping_forces(d, e, v, Qd, Kd, Cd);
        if (r != nullptr)
            for (int i = 0; i < 8; ++i) r[i] += Qd[i];
    }
    if (J == nullptr) return;
    for (int k = 0; k < 64; ++k) J[k] = (need_K ? wK * K[k] : 0.0) + wM * M[k];
    if (d.damped())
        for (int k = 0; k < 64; ++k) J[k] += wK * Kd[k] + wC * Cd[k];
    if (turning) {
        // d f / d e = w^2 S^2 + w_dot S = -w^2 I + w_dot S; d f / d e_dot = 2 w S (S on pairs:
        // column 2k+1 -> row 2k with -1, column 2k -> row 2k+1 with +1)
        for (int i = 0; i < 8; ++i)
            for (int k = 0; k < 4; ++k) {
                const double mx = M[8 * i + 2 * k], my = M[8 * i + 2 * k + 1];  // M S: (M S)_{i,2k} = M_{i,2k+1}
                J[8 * i + 2 * k] += (wK * wd + wC * 2.0 * w) * my - wK * w * w * mx;
                J[8 * i + 2 * k + 1] += -(wK * wd + wC * 2.0 * w) * mx - wK * w * w * my;
            }
    }
}

void ancf_geometric_stiffness(const AncfElementData& d, const double* e, const double* de, double* G) {
    using D = Dual<double, 1>;
    D ed[8], eps[3];
    for (int i = 0; i < 8; ++i) {
        ed[i] = D(e[i]);
        ed[i].d[0] = de[i];
    }
    model_a_strains(d, ed, eps);
    const ModelAMatrices m = model_a_matrices(d);
    for (int k = 0; k < 64; ++k) G[k] = eps[0].d[0] * m.K[0][k] + eps[1].d[0] * m.K[1][k] + eps[2].d[0] * m.K[2][k];
}

double ancf_damping_power(const AncfElementData& d, const double* e, const double* v) {
    if (!d.damped()) return 0.0;
    double Q[8] = {}, K[64], C[64];
    damping_forces(d, e, v, Q, K, C);
    double P = 0.0;
    for (int i = 0; i < 8; ++i) P += v[i] * Q[i];
    return P;
}

void ancf_energies(const AncfElementData& d, const double* e, const double* v, double* kinetic, double* elastic) {
    double M[64];
    ancf_model_a_matrix(d, 4, M);
    double T = 0.0;
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j) T += 0.5 * v[i] * M[8 * i + j] * v[j];
    *kinetic = T;
    double Uf = 0.0;  // the foundation's 1/2 (e - e0)^T K_f (e - e0)
    if (d.k_found != 0.0) {
        double Kf[64];
        expand(hermite::mass, d.l, d.k_found * d.l, Kf);
        for (int i = 0; i < 8; ++i)
            for (int j = 0; j < 8; ++j) Uf += 0.5 * (e[i] - d.e0[i]) * Kf[8 * i + j] * (e[j] - d.e0[j]);
    }
    if (d.elastic == AncfElastic::model_0) {
        *elastic = model_0_energy<double>(d, e) + Uf;
        return;
    }
    const Integrals& I = integrals();
    double eps[3];
    model_a_strains(d, e, eps);
    double U = 0.0;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) U += 0.5 * d.EA * d.l * I.quad[a][b] * eps[a] * eps[b];
    double Kt[64];
    ancf_model_a_matrix(d, 3, Kt);
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j) U += 0.5 * e[i] * Kt[8 * i + j] * e[j];
    *elastic = U + Uf;
}

}  // namespace pipeflex
