"""Exceptions raised by pipeflex analyses.

The C++ core raises the same classes (translated in its bindings), with the same
attributes; no caller needs to parse a message.
"""
from __future__ import annotations

from typing import Optional


class ConvergenceError(RuntimeError):
    """A solver failed; the message says where and why, the attributes say where.

    Every attribute is None when the failing solver does not know it.

    Attributes:
        time: simulated time t [s] at which a time integration failed (the last
            accepted time for generalised-alpha, IDA's current time for IDA).
        iteration: Newton iterations done in the attempt that failed.
        residual: force residual norm at the failure [N] (the largest component
            for multibody systems).
        load_factor: load factor [-] of the load step that failed (static solves).
        mass_flow: mdot [kg/s] at which the solve failed (for
            :func:`~pipeflex.critical_mass_flow`: the trial flow of a failed static
            solve, the lowest unstable flow found if the crossing could not be located,
            the end of the searched range if nothing was unstable).
        reached_mass_flow: for a static solve with a flow ramp, the last flow mdot
            [kg/s] at which it converged.
        reached_state: the equilibrium (:class:`~pipeflex.State`) at ``reached_mass_flow``.
    """

    def __init__(self, message: str, *, time: Optional[float] = None, iteration: Optional[int] = None,
                 residual: Optional[float] = None, load_factor: Optional[float] = None,
                 mass_flow: Optional[float] = None, reached_mass_flow: Optional[float] = None,
                 reached_state=None):
        super().__init__(message)
        self.time = time
        self.iteration = iteration
        self.residual = residual
        self.load_factor = load_factor
        self.mass_flow = mass_flow
        self.reached_mass_flow = reached_mass_flow
        self.reached_state = reached_state


class SingularMatrixError(ConvergenceError):
    """The iteration matrix or tangent of a Newton solve is singular (a mechanism, joints
    that lock a motion twice, a bifurcation point).

    A :class:`ConvergenceError` (same attributes), so that one ``except
    ConvergenceError`` catches every solver failure. Deliberately not a
    ``numpy.linalg.LinAlgError``: analyses catch that around their own linear solves
    to fall back to another method, which must not swallow a failed solve.
    """


class LimitPointError(ConvergenceError):
    """The equilibrium path has a limit point below the requested load: followed by
    arc-length continuation, the load factor turns back at ``load_factor`` and the path
    does not come back to the full load (1) within the continuation's budget.

    A :class:`ConvergenceError` (same attributes): ``load_factor`` [-] is the load
    factor of the limit point (the largest load the structure carries on this path),
    ``reached_state`` the equilibrium (:class:`~pipeflex.State`) there, ``mass_flow``
    its mdot [kg/s] (with a flow ramp ``reached_mass_flow`` too). ``limit_points``: the
    load factors of all limit points passed, in order.
    """

    def __init__(self, message: str, *, limit_points=(), **kwargs):
        super().__init__(message, **kwargs)
        self.limit_points = tuple(limit_points)


class UnitWarning(UserWarning):
    """An input far outside the plausible range of its quantity in SI units, as a unit
    slip gives (a diameter in millimetres, a modulus in GPa, gravity in mm/s^2); the
    message names the parameter, the value and the likely slip. The value is used as
    given. The ranges are wide (docs/conventions.md, Units); to silence the warning for a
    deliberate value: ``warnings.simplefilter("ignore", pipeflex.errors.UnitWarning)``.
    """
