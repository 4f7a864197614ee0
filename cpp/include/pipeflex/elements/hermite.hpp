// Integrals of the cubic Hermite shape functions of seed 000, eq. 9, over xi in [0, 1]:
//   N = [1 - 3xi^2 + 2xi^3, xi - 2xi^2 + xi^3, 3xi^2 - 2xi^3, -xi^2 + xi^3]
// acting on a = [x^p, l0 e^p_x, x^q, l0 e^q_x].
#pragma once

namespace pipeflex::hermite {

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

// int N_i dxi (consistent distributed load).
inline constexpr double load[4] = {0.5, 1.0 / 12, 0.5, -1.0 / 12};


}  // namespace pipeflex::hermite
