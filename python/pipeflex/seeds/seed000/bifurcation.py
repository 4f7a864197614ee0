"""Bifurcation diagram of the flutter limit cycle (beyond seed 000, section 3.2, Fig. 3).

The flutter of the cantilever is a Hopf bifurcation at the critical flow of Table 2;
seed 000 shows one of its periodic orbits (30 kg/s) by a long transient. Here the
orbits are continued in the mass flow from the Hopf point (:func:`pipeflex.continue_orbits`)
in the plane of the tip force (the out-of-plane coordinates fixed), and each planar orbit
is then checked in the full 3D model: its Floquet multipliers there say whether an
out-of-plane disturbance grows (the transient of Fig. 3 starts exactly planar and cannot
tell).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...analysis import critical_mass_flow, continue_orbits, periodic_orbit
from ...analysis.periodic import OrbitBranch, PeriodicOrbit
from .limit_cycle import limit_cycle_model


@dataclass
class Diagram:
    """A branch of planar orbits with their 3D stability.

    Attributes:
        n_elements, tip_force [N]: the scene.
        branch: the planar branch (:class:`~pipeflex.OrbitBranch`; its ``stable`` is
            in-plane stability).
        stable_3d: (k,) stability of each orbit in the 3D model.
        max_multiplier_3d: (k,) largest modulus of the non-trivial 3D multipliers [-].
        at_30: the orbit at exactly 30 kg/s (planar model), for Fig. 3.
    """

    n_elements: int
    tip_force: float
    branch: OrbitBranch
    stable_3d: np.ndarray
    max_multiplier_3d: np.ndarray
    at_30: PeriodicOrbit
    tip: int


#: axial stiffness [N] of the diagram's cantilever: the peer comparison's (the limit cycle
#: of Fig. 3 with EA = 1e11 N differs by 1.5e-4 in amplitude; so stiff an axis leaves the
#: axial velocities a round-off floor of ~1e-7 m/s, above the shooting tolerance)
EA = 1e5


def bifurcation_diagram(n_elements: int, *, tip_force: float = 1.5, mass_flow_end: float = 40.0,
                        steps: int = 400, max_points: int = 60, check_3d: bool = True) -> Diagram:
    """Continue the planar orbits from the Hopf point to ``mass_flow_end`` [kg/s] with
    ``steps`` integrator steps per period, then (``check_3d``) their stability in 3D."""
    planar, tip = limit_cycle_model(n_elements=n_elements, tip_force=tip_force, planar=True, EA=EA)
    full, _ = limit_cycle_model(n_elements=n_elements, tip_force=tip_force, EA=EA)
    hopf = critical_mass_flow(planar)
    branch = continue_orbits(planar, start=hopf, mass_flow_end=mass_flow_end, amplitude=2e-2, steps=steps,
                             max_points=max_points)
    # the orbit at exactly 30 kg/s, from the branch's nearest one
    k = int(np.argmin(np.abs(branch.mass_flow - 30.0)))
    near = continue_orbits_orbit(planar, branch, k, steps)
    at_30 = periodic_orbit(planar, period=near.period, state=near.start, mass_flow=30.0, steps=steps)
    stable, mmax = [], []
    if check_3d:
        for i in range(len(branch.mass_flow)):
            o = continue_orbits_orbit(planar, branch, i, steps)
            o3 = periodic_orbit(full, period=o.period, state=o.start, mass_flow=o.mass_flow, steps=steps)
            stable.append(o3.stable)
            mmax.append(float(np.delete(np.abs(o3.multipliers), o3.trivial).max()))
    return Diagram(n_elements, tip_force, branch, np.array(stable), np.array(mmax), at_30, tip)


def continue_orbits_orbit(model, branch: OrbitBranch, index: int, steps: int) -> PeriodicOrbit:
    """The orbit ``index`` of ``branch`` again (its start state is kept on the branch)."""
    return periodic_orbit(model, period=float(branch.period[index]), state=branch.starts[index],
                          mass_flow=float(branch.mass_flow[index]), steps=steps)


def figure(diagrams, *, transients=(), curves=()):
    """Amplitude and period of the tip's lateral motion against the mass flow, drawn by
    :func:`pipeflex.plot.bifurcation`: one colour per diagram, solid between orbits stable
    in 3D, dashed where unstable (out of plane); the Hopf points as dots; ``transients``:
    (label, mdot [kg/s], amplitude [m], period [s]) marked; ``curves``: (label, mdot,
    amplitudes, periods) of other models (arrays), drawn with square markers. Returns the
    figure."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from ...plot import bifurcation

    fig, (ax_a, ax_t) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    branches = [d.branch for d in diagrams]
    options = dict(node=[d.tip for d in diagrams], component=1, stable=[d.stable_3d for d in diagrams],
                   legend=False)
    bifurcation(branches, quantity="amplitude", ax=ax_a, ylabel=r"tip amplitude $A_y$ [m]", **options)
    bifurcation(branches, quantity="period", ax=ax_t, **options)
    handles = [Line2D([], [], color=f"C{i}", label=f"{d.n_elements} elements, tip force {d.tip_force:g} N")
               for i, d in enumerate(diagrams)]
    for label, mdot, amp, period in transients:
        ax_a.plot(mdot, amp, "k*", ms=9)
        ax_t.plot(mdot, period, "k*", ms=9)
    if transients:
        handles.append(Line2D([], [], color="k", marker="*", ls="none", ms=9, label="long transient (Fig. 3)"))
    for i, (label, mdot, amp, period) in enumerate(curves):
        style = dict(color=f"C{len(diagrams) + i}", marker="s", ms=4, ls=":")
        ax_a.plot(mdot, amp, **style)
        ax_t.plot(mdot, period, **style)
        handles.append(Line2D([], [], label=label, **style))
    handles += [Line2D([], [], color="grey", ls="-", label="stable in 3D"),
                Line2D([], [], color="grey", ls="--", label="unstable out of plane"),
                Line2D([], [], color="grey", ls="none", marker="o", ms=4, label="Hopf point")]
    ax_a.legend(handles=handles, fontsize=8)
    return fig
