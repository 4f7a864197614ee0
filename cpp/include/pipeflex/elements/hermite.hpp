// The cubic Hermite shape functions of seed 000, eq. 9, on xi in [0, 1]:
//   N = [1 - 3xi^2 + 2xi^3, xi - 2xi^2 + xi^3, 3xi^2 - 2xi^3, -xi^2 + xi^3]
// acting on a = [x^p, l0 e^p_x, x^q, l0 e^q_x] (the slope functions N_2, N_4 multiply the
// element length): their values, their integrals in closed form, and the quadrature rule
// for the products that the elements integrate numerically. Every element with a cubic
// Hermite field (pipe, planar ANCF beam, FFRF body) takes them from here.
#pragma once

namespace pipeflex::hermite {

// N_i(xi) and the derivatives dN_i/dxi, d^2N_i/dxi^2.
struct Shape {
    double N[4], dN[4], ddN[4];
};

inline Shape shape(double xi) {
    const double x2 = xi * xi, x3 = x2 * xi;
    return {{1 - 3 * x2 + 2 * x3, xi - 2 * x2 + x3, 3 * x2 - 2 * x3, -x2 + x3},
            {-6 * xi + 6 * x2, 1 - 4 * xi + 3 * x2, 6 * xi - 6 * x2, -2 * xi + 3 * x2},
            {-6 + 12 * xi, -4 + 6 * xi, 6 - 12 * xi, -2 + 6 * xi}};
}

// 4-point Gauss-Legendre on [0, 1], exact to degree 7: the element integrands are at most
// of degree 6 (two shape functions, or two first derivatives times a quadratic weight).
inline constexpr int n_gauss = 4;
inline constexpr double gauss_xi[n_gauss] = {0.0694318442029737, 0.3300094782075719, 0.6699905217924281,
                                             0.9305681557970263};
inline constexpr double gauss_w[n_gauss] = {0.1739274225687269, 0.3260725774312731, 0.3260725774312731,
                                            0.1739274225687269};

// int N_i N_j dxi (the 1/420 Hermite mass matrix of eq. 12).
inline constexpr double mass[4][4] = {{156.0 / 420, 22.0 / 420, 54.0 / 420, -13.0 / 420},
                                      {22.0 / 420, 4.0 / 420, 13.0 / 420, -3.0 / 420},
                                      {54.0 / 420, 13.0 / 420, 156.0 / 420, -22.0 / 420},
                                      {-13.0 / 420, -3.0 / 420, -22.0 / 420, 4.0 / 420}};

// int N_i dN_j/dxi dxi. Its skew part is the Coriolis matrix G/60 of eq. 19; its
// symmetric part gives the split-off end terms.
inline constexpr double first[4][4] = {{-30.0 / 60, 6.0 / 60, 30.0 / 60, -6.0 / 60},
                                       {-6.0 / 60, 0.0, 6.0 / 60, -1.0 / 60},
                                       {-30.0 / 60, -6.0 / 60, 30.0 / 60, 6.0 / 60},
                                       {6.0 / 60, 1.0 / 60, -6.0 / 60, 0.0}};

// int N_i d^2N_j/dxi^2 dxi: the centripetal matrix of eq. 20 plus its end terms.
inline constexpr double second[4][4] = {{-36.0 / 30, -33.0 / 30, 36.0 / 30, -3.0 / 30},
                                        {-3.0 / 30, -4.0 / 30, 3.0 / 30, 1.0 / 30},
                                        {36.0 / 30, 3.0 / 30, -36.0 / 30, 33.0 / 30},
                                        {-3.0 / 30, 1.0 / 30, 3.0 / 30, -4.0 / 30}};

// int dN_i/dxi dN_j/dxi dxi (the stretching stiffness of a Hermite field).
inline constexpr double stretch[4][4] = {{36.0 / 30, 3.0 / 30, -36.0 / 30, 3.0 / 30},
                                         {3.0 / 30, 4.0 / 30, -3.0 / 30, -1.0 / 30},
                                         {-36.0 / 30, -3.0 / 30, 36.0 / 30, -3.0 / 30},
                                         {3.0 / 30, -1.0 / 30, -3.0 / 30, 4.0 / 30}};

// int d^2N_i/dxi^2 d^2N_j/dxi^2 dxi (the bending stiffness).
inline constexpr double bend[4][4] = {{12.0, 6.0, -12.0, 6.0}, {6.0, 4.0, -6.0, 2.0}, {-12.0, -6.0, 12.0, -6.0},
                                      {6.0, 2.0, -6.0, 4.0}};

// int N_i dxi (consistent distributed load).
inline constexpr double load[4] = {0.5, 1.0 / 12, 0.5, -1.0 / 12};

}  // namespace pipeflex::hermite
