"""Every analysis takes any system: pf.critical_mass_flow and
pf.stability of a pipeflex.CoupledSystem (elements and floating-frame bodies joined by
joints), through the one constrained linearisation (pipeflex.analysis.constrained)."""
import numpy as np
import pytest

import pipeflex as pf
from helpers import on_clamped_hub

SEC = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 1e-3, 1e-3))


def cantilever(*, clamped, mass_flow=0.0, reservoir=False, section=SEC):
    """Seed 000's cantilever (8 elements, 1 m, EI = 10 N m^2, 8 + 2 kg/m) from the origin."""
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    b.add_line(root, (1.0, 0.0, 0.0), 8, section)
    if reservoir:
        b.reservoir_inlet(root)
    if clamped:
        b.clamp(root)
    return b.build(mass_flow=mass_flow, floating=not clamped), root


def on_stiff_hub(*, mass_flow=0.0, reservoir=True, section=SEC):
    """The cantilever rigidly joined to a short body 1e6 times stiffer than one as compliant
    as the arm, clamped to the ground (notebooks/coupled_systems.ipynb, section 3)."""
    arm, root = cantilever(clamped=False, mass_flow=mass_flow, reservoir=reservoir, section=section)
    return on_clamped_hub(arm, root, stiffness_ratio=1e6, rotary_inertia=(1.0, 1.0, 1.0))


def test_coupled_critical_flow_is_the_clamped_cantilevers():
    """The cantilever on a stiff clamped hub body loses stability where the clamped
    cantilever does: flutter at 24.985 kg/s (the same mode, 137.5 rad/s), equal to 1e-9
    relative (the hub's compliance). The inlet is fed from a still reservoir: the hub
    carries no fluid (see test_an_inlet_moving_with_a_body_is_named)."""
    alone = pf.critical_mass_flow(cantilever(clamped=True, reservoir=True)[0])
    assert alone.mass_flow == pytest.approx(pf.critical_mass_flow(cantilever(clamped=True)[0]).mass_flow, rel=1e-12)
    got = pf.critical_mass_flow(on_stiff_hub())
    assert got.kind == alone.kind == "flutter"
    assert alone.mass_flow == pytest.approx(24.985, abs=5e-4)
    assert got.mass_flow == pytest.approx(alone.mass_flow, rel=1e-8)
    assert got.frequency == pytest.approx(alone.frequency, rel=1e-8)
    assert abs(got.eigenvalue.real) < 1e-6 * abs(got.eigenvalue)
    assert got.mode.shape == (on_stiff_hub().n_dofs,)


def test_coupled_stability_below_and_above_the_critical_flow():
    """pf.stability of a coupled system: stable below the clamped cantilever's critical
    flow, flutter above; the stiff hub (1e20 N/m axial stiffness) is not a mechanism."""
    for mdot, expected in ((10.0, "stable"), (24.9, "stable"), (25.1, "flutter")):
        system = on_stiff_hub(mass_flow=mdot)
        assert pf.stability(pf.eigenvalues(pf.linearize(system))) == expected


def test_coupled_system_without_flow_effects_is_refused_as_an_element_model_is():
    """No element or body carries fluid: the element path's ValueError, for both."""
    dry = pf.PipeSection(EI=10.0, pipe_mass=10.0, EA=1e5, rotary_inertia=(1e-3, 1e-3, 1e-3))
    with pytest.raises(ValueError, match="carries fluid"):
        pf.critical_mass_flow(cantilever(clamped=True, section=dry)[0])
    with pytest.raises(ValueError, match="no element or body that carries fluid"):
        pf.critical_mass_flow(on_stiff_hub(section=dry))


def test_an_inlet_moving_with_a_body_is_named():
    """Without reservoir_inlet the arm's inlet end term accelerates the incoming fluid to the
    hub's velocity: the hub's modes (9e4 rad/s and up) grow at Re lambda ~ 3e-3 1/s per
    kg/s, linear in the flow (not round-off: the same for hubs 1e2 to 1e6 times stiffer).
    critical_mass_flow does not return a flow then; its error names the inlet and the
    remedy."""
    system = on_stiff_hub(reservoir=False)
    rates = []
    for mdot in (1.0, 10.0):
        eig = pf.eigenvalues(pf.linearize(system, mass_flow=mdot))
        hub = eig.values[np.abs(eig.values.imag) > 1e4]
        rates.append(hub.real.max())
    assert rates[1] == pytest.approx(10 * rates[0], rel=0.05)
    assert 1e-3 < rates[0] < 1e-2
    with pytest.raises(pf.ConvergenceError, match=r"element node\(s\) 0, an inlet .*reservoir_inlet"):
        pf.critical_mass_flow(system)


def test_coupled_critical_flow_refuses_a_foreign_state():
    with pytest.raises(TypeError, match="CoupledStatic"):
        pf.critical_mass_flow(on_stiff_hub(), state=pf.State)


def test_analyses_for_element_models_only_say_so():
    """The analyses that take element models only refuse bodies and coupled systems with a
    TypeError that says so; steady_rotation takes them and asks for their one hinge
    (tests/test_steady_systems.py); the periodic orbits take them (tests/test_body_orbits.py)."""
    bodies = pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=2)
    for system in (bodies, on_stiff_hub()):
        with pytest.raises(ValueError, match=f"needs exactly one hinge .* this {type(system).__name__} has 0"):
            pf.steady_rotation(system)
        for call in (lambda s: pf.rotating_frequencies(s, gamma=1.0), lambda s: pf.campbell(s, gamma=[0.0, 1.0])):
            with pytest.raises(TypeError, match=f"got {type(system).__name__}: this analysis takes element models"):
                call(system)
    with pytest.raises(TypeError, match="also take a MultibodySystem or a CoupledSystem"):
        pf.linearize("cantilever")
