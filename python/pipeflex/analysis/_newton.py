"""The Newton convergence test of the Python analyses (the core's static_newton has the same)."""

# a correction within this many tolerances that no longer halves is round-off
ROUNDOFF_STALL = 1e3


def converged(error: float, last: float, tol: float) -> bool:
    """Whether Newton has converged: the relative correction ``error`` is below ``tol``, or
    it has stalled at round-off (within ROUNDOFF_STALL tol and not below half the previous
    correction ``last``; inf before the first). Fine meshes of stiff structures reach
    their round-off floor above tight tolerances."""
    return error <= tol or (error <= ROUNDOFF_STALL * tol and error >= 0.5 * last)
