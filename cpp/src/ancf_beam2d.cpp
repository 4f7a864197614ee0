#include "pipeflex/elements/ancf_beam2d.hpp"

#include "pipeflex/core/dual.hpp"

#include <array>
#include <cmath>

namespace pipeflex {
namespace {

// Hermite shape functions on xi in [0, 1] and their xi-derivatives (coefficients of
// 1, xi, xi^2, xi^3); slope functions scaled by l in the element matrices.
constexpr double H[4][4] = {{1, 0, -3, 2}, {0, 1, -2, 1}, {0, 0, 3, -2}, {0, 0, -1, 1}};

double poly(const double* c, double x) { return c[0] + x * (c[1] + x * (c[2] + x * c[3])); }
double dpoly(const double* c, double x) { return c[1] + x * (2 * c[2] + 3 * x * c[3]); }
double ddpoly(const double* c, double x) { return 2 * c[2] + 6 * x * c[3]; }

// Integrals over xi in [0, 1] by 5-point Gauss-Legendre (exact to degree 9).
struct Integrals {
    double mass[4][4];      // int s_i s_j
    double axial[3][4][4];  // int N_X s_i' s_j'  (X = A, M, B)
    double bend[4][4];      // int s_i'' s_j''
};

const Integrals& integrals() {
    static const Integrals I = [] {
        Integrals r{};
        const double x[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640};
        const double w[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665,
                             0.2369268850561891};
        for (int g = 0; g < 5; ++g) {
            const double xi = 0.5 * (x[g] + 1.0), wg = 0.5 * w[g];
            const double N[3] = {1 - 4 * xi + 3 * xi * xi, 6 * xi - 6 * xi * xi, -2 * xi + 3 * xi * xi};
            for (int i = 0; i < 4; ++i)
                for (int j = 0; j < 4; ++j) {
                    r.mass[i][j] += wg * poly(H[i], xi) * poly(H[j], xi);
                    for (int k = 0; k < 3; ++k) r.axial[k][i][j] += wg * N[k] * dpoly(H[i], xi) * dpoly(H[j], xi);
                    r.bend[i][j] += wg * ddpoly(H[i], xi) * ddpoly(H[j], xi);
                }
        }
        return r;
    }();
    return I;
}

// 8x8 matrix c * int f_i f_j with f = [s1, l s2, s3, l s4] on both components.
void expand(const double (&m)[4][4], double l, double c, double* out) {
    const double sc[4] = {1.0, l, 1.0, l};
    for (int k = 0; k < 64; ++k) out[k] = 0.0;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            for (int comp = 0; comp < 2; ++comp) out[8 * (2 * i + comp) + 2 * j + comp] = c * sc[i] * sc[j] * m[i][j];
}

template <class S>
void elastic_forces(const AncfElementData& d, const double (&K)[4][64], const S* e, S* Q) {
    using std::sqrt;
    const S eA = sqrt(e[2] * e[2] + e[3] * e[3]) - 1.0;
    const S eM = sqrt((e[4] - e[0]) * (e[4] - e[0]) + (e[5] - e[1]) * (e[5] - e[1])) / d.l - 1.0;
    const S eB = sqrt(e[6] * e[6] + e[7] * e[7]) - 1.0;
    for (int i = 0; i < 8; ++i) {
        S q = S(0.0);
        for (int j = 0; j < 8; ++j) q += (eA * K[0][8 * i + j] + eM * K[1][8 * i + j] + eB * K[2][8 * i + j] + S(K[3][8 * i + j])) * e[j];
        Q[i] = q;
    }
}

}  // namespace

void ancf_model_a_matrix(const AncfElementData& d, int which, double* out) {
    const Integrals& I = integrals();
    const double l = d.l;
    if (which >= 0 && which < 3) {
        expand(I.axial[which], l, d.EA / l, out);
    } else if (which == 3) {
        expand(I.bend, l, d.EI / (l * l * l), out);
    } else {
        expand(I.mass, l, d.mass * l, out);
        out[8 * 4 + 4] += d.tip_mass;
        out[8 * 5 + 5] += d.tip_mass;
    }
}

void ancf_model_a_tangent(const AncfElementData& d, const double* e, const double* v, const double* a, double wK,
                          double wC, double wM, double* r, double* J) {
    // No velocity dependence (absolute coordinates, constant mass matrix): wC has no term.
    (void)v;
    (void)wC;
    double K[4][64], M[64];
    for (int k = 0; k < 4; ++k) ancf_model_a_matrix(d, k, K[k]);
    ancf_model_a_matrix(d, 4, M);
    double Q[8];
    elastic_forces<double>(d, K, e, Q);
    for (int i = 0; i < 8; ++i) {
        double ma = 0.0;
        for (int j = 0; j < 8; ++j) ma += M[8 * i + j] * a[j];
        if (r != nullptr) r[i] = ma + Q[i];
    }
    if (J == nullptr) return;
    using D = Dual<double, 8>;
    D ed[8], Qd[8];
    for (int i = 0; i < 8; ++i) ed[i] = D(e[i], i);
    elastic_forces<D>(d, K, ed, Qd);
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j) J[8 * i + j] = wK * Qd[i].d[j] + wM * M[8 * i + j];
}

}  // namespace pipeflex
