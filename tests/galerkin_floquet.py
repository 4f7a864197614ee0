"""An independent Galerkin-Floquet solver of the pipe conveying a pulsating flow: the
reference of tests/test_parametric.py. It imports no pipeflex code (only numpy and scipy).

The Euler-Bernoulli pipe of Paidoussis & Issid (1974), plug flow, no dissipation, one
bending plane, lateral deflection w(x, t) on 0 <= x <= L:

    (m + M) w_tt + 2 mdot w_xt + (mdot^2 / M - N(x, t)) w_xx + EI w_xxxx = 0,

mdot(t) = mdot0 (1 + mu sin(Omega t)) [kg/s] the mass flow (mdot = M U), and N the axial
force [N] (tension > 0) that the fluid's acceleration puts into the pipe: the fluid
pushes on the wall with -mdot' [N/m] along the axis, so N' = mdot' and
N = mdot' (x - c), c the point where N vanishes: the end free to move axially (c = L for
a free outlet, Paidoussis' M U' (L - x) w_xx; c = 0 if only the outlet is held axially),
c = L / 2 for both ends held axially. (The lateral part of that tangential load,
-mdot' w_x, cancels the term -N' w_x of (N w_x)_x, so it appears in neither.)

Galerkin with the beam's own modes phi_n (pinned-pinned: sin(n pi x / L); clamped-free
and clamped-clamped: the beam's eigenfunctions), quadrature by Gauss-Legendre, gives

    Mg q'' + 2 mdot B q' + (EI S + mdot^2 / M D2 - mdot' Dx) q = 0,

whose monodromy matrix over T = 2 pi / Omega is integrated by scipy's DOP853 at
rtol 1e-11: another discretisation (global modes, not finite elements) and another
integrator (explicit Runge-Kutta, not Magnus) than pipeflex's.
"""
import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq


def _cantilever_roots(n):
    f = lambda b: np.cos(b) + 1.0 / np.cosh(b)  # 1 + cos b cosh b = 0, scaled
    return np.array([brentq(f, (k + 0.5) * np.pi - 1.0, (k + 0.5) * np.pi + 1.0, xtol=1e-15) for k in range(n)])


def _clamped_roots(n):
    f = lambda b: np.cos(b) - 1.0 / np.cosh(b)  # cos b cosh b = 1, scaled
    return np.array([brentq(f, (k + 1.5) * np.pi - 1.0, (k + 1.5) * np.pi + 1.0, xtol=1e-15) for k in range(n)])


def _clamped_basis(n, L, x):
    """The clamped-clamped beam's eigenfunctions phi = cosh - cos - sigma (sinh - sin),
    sigma = (cosh bL - cos bL) / (sinh bL - sin bL), written as the cantilever's."""
    b = _clamped_roots(n)[:, None] / L
    bL = b * L
    sigma = (np.cosh(bL) - np.cos(bL)) / (np.sinh(bL) - np.sin(bL))
    one_minus = (-np.exp(-bL) - np.sin(bL) + np.cos(bL)) / (np.sinh(bL) - np.sin(bL))
    bx = b * x
    e, sh = np.exp(-bx), np.sinh(bx)
    phi = e + one_minus * sh - np.cos(bx) + sigma * np.sin(bx)
    d1 = b * (-e + one_minus * np.cosh(bx) + np.sin(bx) + sigma * np.cos(bx))
    d2 = b ** 2 * (e + one_minus * sh + np.cos(bx) - sigma * np.sin(bx))
    return phi, d1, d2, b ** 4 * phi


def basis(support, n, L, x):
    """(phi, phi', phi'', phi'''') at x, each (n, len(x)); ``support`` "pinned", "cantilever"
    or "clamped" (clamped-clamped)."""
    if support == "pinned":
        k = np.arange(1, n + 1)[:, None] * np.pi / L
        s, c = np.sin(k * x), np.cos(k * x)
        return s, k * c, -k ** 2 * s, k ** 4 * s
    if support == "clamped":
        return _clamped_basis(n, L, x)
    if support != "cantilever":
        raise ValueError(support)
    b = _cantilever_roots(n)[:, None] / L
    bL = b * L
    # phi = cosh - cos - sigma (sinh - sin) written without the cancellation of cosh - sigma sinh
    sigma = (np.cosh(bL) + np.cos(bL)) / (np.sinh(bL) + np.sin(bL))
    one_minus = (np.sin(bL) - np.cos(bL) - np.exp(-bL)) / (np.sinh(bL) + np.sin(bL))
    bx = b * x
    e, sh = np.exp(-bx), np.sinh(bx)
    phi = e + one_minus * sh - np.cos(bx) + sigma * np.sin(bx)
    d1 = b * (-e + one_minus * np.cosh(bx) + np.sin(bx) + sigma * np.cos(bx))
    d2 = b ** 2 * (e + one_minus * sh + np.cos(bx) - sigma * np.sin(bx))
    return phi, d1, d2, b ** 4 * phi


def matrices(support, *, n_modes, L, EI, pipe_mass, fluid_mass, c, n_quad=400):
    """Galerkin matrices (Mg, B, S, D2, Dx) of the pipe equation (module docstring)."""
    xg, wg = np.polynomial.legendre.leggauss(n_quad)
    x, w = 0.5 * L * (xg + 1.0), 0.5 * L * wg
    p, d1, d2, d4 = basis(support, n_modes, L, x)
    inner = lambda f, g: (f * w) @ g.T
    return ((pipe_mass + fluid_mass) * inner(p, p), inner(p, d1), EI * inner(p, d4), inner(p, d2) / fluid_mass,
            inner(p * (x - c), d2))


class Pipe:
    """The Galerkin pipe: ``support`` "pinned" (pinned-pinned), "cantilever" (clamped at
    x = 0, free at x = L) or "clamped" (clamped at both ends); ``c`` [m] where the axial
    force vanishes (default L: the outlet free to slide axially; L / 2 for both ends held)."""

    def __init__(self, support, *, L=1.0, EI=1.0, pipe_mass=0.75, fluid_mass=0.25, n_modes=8, c=None):
        self.L, self.fluid_mass = L, fluid_mass
        self.Mg, self.B, self.S, self.D2, self.Dx = matrices(support, n_modes=n_modes, L=L, EI=EI,
                                                             pipe_mass=pipe_mass, fluid_mass=fluid_mass,
                                                             c=L if c is None else c)
        self.Mi = np.linalg.inv(self.Mg)
        self.n = n_modes

    def system(self, mdot, rate):
        """First-order matrix A: x' = A x, x = [q; q'] at flow mdot [kg/s] and rate mdot' [kg/s^2]."""
        n = self.n
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -self.Mi @ (self.S + mdot ** 2 * self.D2 - rate * self.Dx)
        A[n:, n:] = -self.Mi @ (2.0 * mdot * self.B)
        return A

    def frequencies(self, mdot):
        """Positive imaginary parts [rad/s] of the steady-flow eigenvalues, ascending."""
        lam = np.linalg.eigvals(self.system(mdot, 0.0))
        return np.sort(lam.imag[lam.imag > 1e-9])

    def eigenvalues(self, mdot):
        return np.linalg.eigvals(self.system(mdot, 0.0))

    def multipliers(self, mdot0, mu, Omega, *, rtol=1e-11):
        """Floquet multipliers of mdot(t) = mdot0 (1 + mu sin(Omega t)) over one period."""
        n2 = 2 * self.n

        def rhs(t, y):
            A = self.system(mdot0 * (1.0 + mu * np.sin(Omega * t)), mdot0 * mu * Omega * np.cos(Omega * t))
            return (A @ y.reshape(n2, n2)).ravel()

        sol = solve_ivp(rhs, (0.0, 2 * np.pi / Omega), np.eye(n2).ravel(), method="DOP853", rtol=rtol,
                        atol=rtol * 1e-2)
        return np.linalg.eigvals(sol.y[:, -1].reshape(n2, n2))

    def largest(self, mdot0, mu, Omega):
        return float(np.abs(self.multipliers(mdot0, mu, Omega)).max())
