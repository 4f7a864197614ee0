"""An independent solver for the cantilevered pipe conveying fluid as a continuous beam: the
reference against which tests/test_stability_map.py and notebooks/stability_map.ipynb check
:func:`pipeflex.stability_map`.

It imports no pipeflex code (only numpy and scipy): no finite element, assembly or solver of
the package enters its numbers, so an agreement is evidence, not a tautology.

The Euler-Bernoulli pipe of Gregory & Paidoussis (1966), plug flow, clamped at x = 0 and
free at x = L, optionally under gravity along its axis and with Kelvin-Voigt and external
viscous damping (Paidoussis, "Fluid-Structure Interactions", vol. 1, eqs. 3.38 and 3.70):

    EI (1 + eta d/dt) w'''' + [M U^2 - (M + m) g (L - x)] w'' + (M + m) g w'
    + 2 M U w_t' + c w_t + (M + m) w_tt = 0,

g > 0 hanging (gravity from the clamp towards the free end). With xi = x / L,
tau = t sqrt(EI / (M + m)) / L^2, u = U L sqrt(M / EI), beta = M / (M + m),
gamma = (M + m) g L^3 / EI, the dissipation alpha = eta sqrt(EI / (M + m)) / L^2 (internal,
Kelvin-Voigt: eta [s] the retardation time) and sigma = c L^2 / sqrt(EI (M + m)) (external,
c [N s/m^2] per unit length), and w = L W(xi) exp(i omega tau):

    (1 + i alpha omega) W'''' + [u^2 - gamma (1 - xi)] W'' + (gamma + 2 i sqrt(beta) u omega) W'
    + (i sigma omega - omega^2) W = 0,
    W(0) = W'(0) = 0,  W''(1) = W'''(1) = 0.

The free end's moment and shear carry the factor 1 + i alpha omega, which drops out.

A complex omega is an eigenvalue where the 2x2 determinant of the free-end conditions of
the two solutions that satisfy the clamped ones vanishes. Without gravity the equation
has constant coefficients: W = sum_j A_j exp(i k_j xi), k_j the roots of
(1 + i alpha omega) k^4 - u^2 k^2 - 2 sqrt(beta) u omega k + i sigma omega - omega^2 = 0, and the
4x4 boundary determinant (divided by the Vandermonde product of the k_j, which makes it independent of the
roots' order and analytic in omega) is :func:`delta_roots`; :func:`delta_transfer` is the
same determinant from the transfer matrix exp(A) of the first-order system (any gamma:
a product of midpoint exponentials over n_steps slices, exact for gamma = 0).
The e^{i omega tau} convention: Im omega < 0 grows (unstable).

:func:`critical` scans u with a Chebyshev collocation of the same equation (all its
eigenvalues at once, so that no mode is missed where the lowest ones trade places), and
locates the flutter speed with the determinant: Brent's method on Im omega of its root.
"""
import numpy as np
import scipy.linalg as sla
from scipy.optimize import brentq


def _damped(alpha, sigma):
    """Whether the dissipation alpha [-], sigma [-] is not zero (checked: >= 0, finite)."""
    for name, x in (("alpha", alpha), ("sigma", sigma)):
        if not (np.isfinite(x) and x >= 0.0):
            raise ValueError(f"{name} must be finite and >= 0 (dimensionless damping), got {x!r}")
    return alpha != 0.0 or sigma != 0.0


def delta_roots(omega, u, beta, *, alpha=0.0, sigma=0.0):
    """The boundary determinant from the four exponentials (gamma = 0).

    omega [-] complex dimensionless frequency omega_bar; u [-] flow speed; beta [-] mass ratio
    M / (M + m), in [0, 1]; alpha [-] Kelvin-Voigt and sigma [-] viscous damping (>= 0)."""
    s = np.sqrt(beta)
    if _damped(alpha, sigma):
        k = np.roots([1.0 + 1j * alpha * omega, 0.0, -u * u, -2.0 * s * u * omega,
                      1j * sigma * omega - omega * omega])
    else:
        k = np.roots([1.0, 0.0, -u * u, -2.0 * s * u * omega, -omega * omega])
    e = np.exp(1j * k)
    ik = 1j * k
    A = np.array([np.ones(4), ik, ik ** 2 * e, ik ** 3 * e])
    vander = np.prod([k[j] - k[i] for i in range(4) for j in range(i + 1, 4)])
    return np.linalg.det(A) / vander


def _system(omega, u, beta, gamma, xi, alpha=0.0, sigma=0.0):
    """A of Y' = A Y, Y = (W, W', W'', W''') at xi."""
    A = np.zeros((4, 4), complex)
    A[0, 1] = A[1, 2] = A[2, 3] = 1.0
    A[3, 0] = omega * omega
    A[3, 1] = -(gamma + 2j * np.sqrt(beta) * u * omega)
    A[3, 2] = -(u * u - gamma * (1.0 - xi))
    if alpha != 0.0 or sigma != 0.0:
        A[3, 0] -= 1j * sigma * omega
        A[3] /= 1.0 + 1j * alpha * omega
    return A


def delta_transfer(omega, u, beta, gamma=0.0, n_steps=1, *, alpha=0.0, sigma=0.0):
    """det of the (W'', W''') at xi = 1 of the solutions with W''(0) = 1 and W'''(0) = 1.

    omega [-], u [-], beta [-], alpha [-], sigma [-] as :func:`delta_roots`; gamma [-] gravity
    (M + m) g L^3 / EI, > 0 hanging; n_steps [-] slices of the transfer matrix when gamma != 0."""
    _damped(alpha, sigma)
    Phi = np.eye(4, dtype=complex)
    n = 1 if gamma == 0.0 else n_steps
    for i in range(n):
        Phi = sla.expm(_system(omega, u, beta, gamma, (i + 0.5) / n, alpha, sigma) / n) @ Phi
    return np.linalg.det(Phi[2:4, 2:4])


def eigenvalue(delta, guess, *, tol=1e-12, max_iterations=60):
    """A root omega of delta(omega) near ``guess`` (secant method in the complex plane).

    delta: a function of the complex omega [-]; guess [-] the starting omega; tol [-] relative
    step at which to stop; max_iterations [-] before RuntimeError."""
    x0, x1 = complex(guess), complex(guess) * (1 + 1e-4) + 1e-4
    f0, f1 = delta(x0), delta(x1)
    for _ in range(max_iterations):
        if f1 == f0:
            break
        x2 = x1 - f1 * (x1 - x0) / (f1 - f0)
        if abs(x2 - x1) <= tol * max(1.0, abs(x2)):
            return x2
        x0, f0, x1, f1 = x1, f1, x2, delta(x2)
    raise RuntimeError(f"no root near {guess}")


def chebyshev(n):
    """Chebyshev points on [0, 1] (xi_0 = 0 ... xi_n = 1) and the differentiation matrix
    (Trefethen, "Spectral Methods in MATLAB", cheb.m, mapped to [0, 1])."""
    x = np.cos(np.pi * np.arange(n + 1) / n)
    c = np.hstack([2.0, np.ones(n - 1), 2.0]) * (-1.0) ** np.arange(n + 1)
    X = np.tile(x, (n + 1, 1)).T
    D = np.outer(c, 1.0 / c) / (X - X.T + np.eye(n + 1))
    D -= np.diag(D.sum(axis=1))
    return (1.0 + x[::-1]) / 2.0, 2.0 * D[::-1, ::-1]


def collocation_eigenvalues(u, beta, gamma=0.0, n=40, *, alpha=0.0, sigma=0.0):
    """All finite omega_bar of the Chebyshev collocation of the equation (n + 1 points; the
    boundary conditions replace the rows of xi = 0, the first interior point, the last
    interior point and xi = 1): a global view, to find which mode goes unstable first.
    alpha [-], sigma [-]: the damping of :func:`delta_roots`."""
    xi, D = chebyshev(n)
    D2 = D @ D
    D3, D4 = D2 @ D, D2 @ D2
    I = np.eye(n + 1)
    K = D4 + (u * u - gamma * (1.0 - xi))[:, None] * D2 + gamma * D
    G = 2j * np.sqrt(beta) * u * D      # times omega
    if _damped(alpha, sigma):
        G = G + 1j * alpha * D4 + 1j * sigma * I
    Mm = -I.astype(complex)             # times omega^2
    rows = {0: I[0], 1: D[0], n - 1: D2[n], n: D3[n]}
    K = K.astype(complex)
    for r, row in rows.items():
        K[r], G[r], Mm[r] = row, 0.0, 0.0
    m = n + 1
    Z = np.zeros((m, m))
    # (K + omega G + omega^2 Mm) W = 0 as A y = omega B y, y = (W, omega W)
    A = np.block([[Z, I], [-K, -G]])
    B = np.block([[I, Z], [Z, Mm]])
    w = sla.eig(A, B, right=False)
    return w[np.isfinite(w)]


def _solver(beta, gamma, n_steps, alpha=0.0, sigma=0.0):
    if gamma == 0.0:
        return lambda w, u: delta_roots(w, u, beta, alpha=alpha, sigma=sigma)
    return lambda w, u: delta_transfer(w, u, beta, gamma, n_steps, alpha=alpha, sigma=sigma)


def _unstable(u, beta, gamma, omega_max, alpha=0.0, sigma=0.0):
    """The collocation eigenvalue of an oscillating mode (Re omega > 0) with the most
    negative Im omega, below omega_max."""
    w = collocation_eigenvalues(u, beta, gamma, alpha=alpha, sigma=sigma)
    w = w[(w.real > 1e-6) & (np.abs(w) < omega_max)]
    return w[np.argmin(w.imag)]


def critical(beta, *, gamma=0.0, u_max=30.0, du=0.05, omega_max=150.0, n_steps=256, alpha=0.0, sigma=0.0):
    """(u_cr, omega_cr): the lowest u at which an oscillating mode's Im omega_bar goes through 0
    (flutter).

    beta [-] mass ratio M / (M + m), in [0, 1]; gamma [-] gravity (M + m) g L^3 / EI, > 0
    hanging; u_max [-] highest u scanned; du [-] step of the scan, > 0; omega_max [-] modes
    above ``|omega_bar| = omega_max`` are ignored; n_steps [-] slices of the transfer matrix
    (gamma != 0); alpha [-] Kelvin-Voigt and sigma [-] viscous damping as :func:`delta_roots`.

    The scan in steps of du uses the collocation; the crossing is located by
    Brent's method on Im of the root of the boundary determinant (secant method from the
    collocation eigenvalue), to 1e-12. Divergence (a real eigenvalue through 0) is not sought."""
    if not 0.0 <= beta <= 1.0:
        raise ValueError(f"beta must lie in [0, 1] (the mass ratio M / (M + m)), got {beta!r}")
    if not (du > 0.0 and u_max > du):
        raise ValueError(f"du must be > 0 and u_max > du, got du = {du!r}, u_max = {u_max!r}")
    _damped(alpha, sigma)
    delta = _solver(beta, gamma, n_steps, alpha, sigma)
    lo, w_lo = 0.0, _unstable(0.0, beta, gamma, omega_max, alpha, sigma)
    while True:
        hi = lo + du
        if hi > u_max:
            raise RuntimeError(f"no flutter up to u = {u_max}")
        w_hi = _unstable(hi, beta, gamma, omega_max, alpha, sigma)
        if w_hi.imag < -1e-8 * abs(w_hi):  # not round-off
            break
        lo = hi
    # the same mode at lo: the collocation eigenvalue nearest the unstable one
    w = collocation_eigenvalues(lo, beta, gamma, alpha=alpha, sigma=sigma)
    w_lo = w[np.argmin(np.abs(w - w_hi))]
    w_lo, w_hi = (eigenvalue(lambda y: delta(y, x), g) for x, g in ((lo, w_lo), (hi, w_hi)))
    root = {}

    def im(x):
        guess = w_lo + (w_hi - w_lo) * (x - lo) / (hi - lo)
        root[x] = eigenvalue(lambda y: delta(y, x), guess)
        return root[x].imag

    uc = brentq(im, lo, hi, xtol=1e-13, rtol=1e-13)
    if uc not in root:
        im(uc)
    return uc, root[uc].real
