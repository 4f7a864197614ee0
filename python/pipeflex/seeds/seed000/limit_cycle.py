"""The flutter limit cycle of the cantilever pipe (seed 000, section 3.2, Fig. 3).

The cantilever of Table 2 is deflected statically by a lateral tip force of 1.5 N
(about 0.05 m without flow); then a mass flow of 30 kg/s, above the flutter flow of
25.0 kg/s, starts at t = 0 and the tip motion grows into a limit cycle. The tip force
stays applied. Cycle metrics (amplitude, period) are measured on the tip's lateral
displacement after the transient has settled.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Tuple

import numpy as np

from ... import _checks
from ...analysis import TransientResult, simulate, static_equilibrium
from ...model import Model, ModelBuilder
from ...sections import PipeSection
from ...signals import cycle_metrics


@dataclass
class LimitCycle:
    """A simulated limit cycle.

    Attributes:
        n_elements: elements of the model. tip: the tip node.
        result: the transient (:class:`~pipeflex.TransientResult`).
        amplitude: half the peak-to-peak tip displacement [m] after ``settle``.
        period: mean time between upward crossings of the mean [s].
        mean: mean tip displacement [m] (not zero: the tip force stays applied).
    """

    n_elements: int
    tip: int
    result: TransientResult
    amplitude: float
    period: float
    mean: float

    @property
    def tip_deflection(self) -> np.ndarray:
        """Lateral (y) tip displacement [m] at the output times."""
        return self.result.x[:, self.tip, 1]


def limit_cycle_model(*, n_elements: int, tip_force: float = 1.5, mass_flow: float = 30.0,
                      polar_inertia: float = 1e-3, planar: bool = False, EA: float = 1e11) -> Tuple[Model, int]:
    """The cantilever of Table 2 (L = 1 m, EI = 10 N m^2, 8 and 2 kg/m) with a lateral tip
    force ``tip_force`` [N] along y and mdot = ``mass_flow`` [kg/s]. ``polar_inertia``
    [kg m] about the pipe axis makes the mass matrix regular (no effect on bending).
    ``planar`` fixes the out-of-plane coordinates (uz, rx, ry) of every node: the motion
    in the x-y plane only. ``EA`` [N]: the axial stiffness (1e11: practically
    inextensible; 1e5, as the peer comparison, keeps the axial modes slow enough for the
    periodic-orbit solver's tolerances). Returns the model and its tip node."""
    sec = PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=_checks.positive("EA", EA),
                      rotary_inertia=(_checks.non_negative("polar_inertia", polar_inertia), 0.0, 0.0))
    b = ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n_elements, sec)
    b.clamp(n0)
    if planar:
        for k in nodes[1:]:
            b.fix(k, ("uz", "rx", "ry"))
    b.add_load(nodes[-1], force=(0.0, _checks.finite("tip_force", tip_force), 0.0))
    return b.build(mass_flow=_checks.finite("mass_flow", mass_flow)), nodes[-1]


#: the transient's accuracy unless ``step`` or ``rtol`` is given: the cycle's amplitude and
#: period within 1.3e-6 ... 1.3e-5 (m, s) of a 0.125 ms step's (fixed 0.5 ms steps: 2e-6 ... 3e-6),
#: in about 0.6-1.0 of the fixed 0.5 ms step's CPU time (4 and 16 elements at EA 1e11 N, 8 and 2
#: at 1e5 N, 6 s; rtol 3e-4 took up to 1.03 of it)
LIMIT_CYCLE_RTOL = 5e-4


def simulate_limit_cycle(n_elements: int, *, t_end: float = 6.0, settle: float = 3.0,
                         integrator: str = "generalized_alpha", n_outputs: int = 2401, EA: float = 1e11,
                         **options) -> LimitCycle:
    """Static deflection by the tip force without flow, then the transient with flow.

    Args:
        n_elements: elements of the cantilever.
        t_end: simulated time [s]; settle: start of the cycle measurement [s].
        integrator, n_outputs, options: as :func:`pipeflex.simulate` (default
            generalised-alpha at ``rtol`` :data:`LIMIT_CYCLE_RTOL`, unless ``step`` or
            ``rtol`` is given).
        EA: axial stiffness [N] (:func:`limit_cycle_model`).
    """
    model, tip = limit_cycle_model(n_elements=n_elements, EA=EA)
    start = static_equilibrium(model, mass_flow=0.0).state
    if integrator == "generalized_alpha" and "rtol" not in options and "step" not in options:
        options["rtol"] = LIMIT_CYCLE_RTOL
    res = simulate(model, t_end, integrator=integrator, state=start, n_outputs=n_outputs, **options)
    amp, period, mean = cycle_metrics(res.t, res.x[:, tip, 1], after=settle)
    return LimitCycle(n_elements, tip, res, amp, period, mean)
