"""Seed 000, section 4: the U-shaped Coriolis mass-flow rate meter (Figs. 6-8)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.seeds.seed000 import coriolis

A = coriolis.RADIUS  # a = 150 mm


def _unit_mass(fluid_density):
    sec = pf.PipeSection.tube(outer_diameter=0.0508, inner_diameter=0.0472, E=208e9, G=80e9, density=8027.0,
                              fluid_density=fluid_density)
    return sec.pipe_mass + sec.fluid_mass


@pytest.mark.parametrize("fluid_density", [coriolis.WATER, coriolis.KEROSENE])
def test_mass_of_the_meter(fluid_density):
    """Total mass (rho_p A_p + rho_f A_f)(2b + pi a); the curved elements' reference
    length (the strain-free l0) is 1.4e-5 (relative) shorter than their arc of pi/12,
    4.5e-6 of the whole pipe.

    The assembled mass matrix agrees: a unit translation of all free nodes (the two
    clamped end nodes held) has the kinetic mass m'(2b + pi a) - 2 m' l_e (1 - 156/420),
    the Hermite mass of the two elements at the clamps lacking their clamped node's share.
    """
    b = 0.495
    model = pf.scenes.coriolis_meter(leg_length=b, fluid_density=fluid_density)
    mu = _unit_mass(fluid_density)
    expected = mu * (2 * b + np.pi * A)
    assert model.total_mass == pytest.approx(expected, rel=1e-5)
    M = pf.linearize(model).M
    free = range(1, model.n_nodes - 1)
    held = expected - 2 * mu * (b / 2) * (1 - 156 / 420)
    for comp in ("ux", "uy", "uz"):
        t = np.zeros(model.n_dofs)
        t[[model.dof_index(n, comp) for n in free]] = 1.0
        assert t @ (M @ t) == pytest.approx(held, rel=1e-5)


def test_geometry_and_sensors():
    """The arc joins the legs tangentially at S1 = (b, -a, 0) and S2 = (b, a, 0), nodes
    elements_per_leg and elements_per_leg + arc_elements; the pipe lies in z = 0."""
    b = 0.4
    model = pf.scenes.coriolis_meter(leg_length=b, elements_per_leg=3, arc_elements=8)
    assert coriolis.sensors(model) == (3, 11)
    assert model.n_nodes == 15
    np.testing.assert_allclose(model.positions[3], (b, -A, 0.0), atol=1e-15)
    np.testing.assert_allclose(model.positions[11], (b, A, 0.0), atol=1e-15)
    np.testing.assert_allclose(model.positions[:, 2], 0.0, atol=1e-15)
    s = coriolis.arc_length(model)
    assert s[-1] == pytest.approx(2 * b + np.pi * A, rel=1e-4)  # l0 of 8 arc elements: -7e-5 each


@pytest.mark.parametrize("flow_scaled", [0.0, 0.1, 0.4])
def test_gyroscopic_and_conservative(flow_scaled):
    """No damping at zero flow; with flow C is skew-symmetric (gyroscopic), K symmetric
    about the static equilibrium, and all eigenvalues stay on the imaginary axis
    (measured max |Re|/|lambda| ~ 3e-12): no flutter (seed 000, section 4)."""
    model = pf.scenes.coriolis_meter(leg_length=3 * A)
    mdot = flow_scaled * coriolis.scales(model).mass_flow0
    st = pf.static_equilibrium(model, mass_flow=mdot)
    lin = pf.linearize(model, st.state, mass_flow=mdot)
    C, K = lin.C.toarray(), lin.K.toarray()
    if flow_scaled == 0.0:
        assert not np.any(C)
    else:
        assert np.abs(C).max() > 0.0
        assert np.abs(C + C.T).max() <= 1e-12 * np.abs(C).max()
    assert np.abs(K - K.T).max() <= 1e-12 * np.abs(K).max()
    eig = pf.eigenvalues(lin)
    assert len(eig.values) == 2 * model.n_dofs
    assert np.max(np.abs(eig.values.real) / np.abs(eig.values)) < 1e-10
    assert pf.stability(eig) == "stable"


def test_fig7_first_frequency():
    """Fig. 7 (b = 3a, water): omega/omega0 = 0.17720 at zero flow, inside the seed's
    plotted range 0.06..0.18, decreasing monotonically to 0.16170 at mdot/mdot0 = 0.4.
    Neglecting the flow's normal force (linearising about the undeformed shape, as [9]
    did) the drop is much larger (to 0.038): 'the reduction of the natural frequency is
    much less than was predicted in [9]'."""
    f = np.linspace(0.0, 0.4, 9)
    c = coriolis.frequency_curve(leg_length=3 * A, flows_scaled=f)
    w = c.omega_scaled
    assert 0.06 < w[0] < 0.18
    assert w[0] == pytest.approx(0.17720, abs=5e-5)
    assert np.all(np.diff(w) < 0.0)
    assert w[-1] == pytest.approx(0.16170, abs=5e-5)
    no_normal = coriolis.frequency_curve(leg_length=3 * A, flows_scaled=[0.0, 0.4], about_equilibrium=False)
    assert no_normal.omega_scaled[0] == pytest.approx(w[0], rel=1e-12)
    assert (no_normal.omega_scaled[0] - no_normal.omega_scaled[-1]) > 5 * (w[0] - w[-1])


def test_first_mode_is_the_swinging_mode():
    """The first mode moves out of the plane, symmetrically (|w(S1)| = |w(S2)|) at zero
    flow with both sensors in phase; with flow the amplitudes stay equal and only the
    phases differ."""
    model = pf.scenes.coriolis_meter(leg_length=coriolis.LEG_FIG8)
    s1, s2 = coriolis.sensors(model)
    for mdot in (0.0, 20.0):
        m = coriolis.first_mode(model, mass_flow=mdot)
        w = m.out_of_plane
        assert np.linalg.norm(m.shape[:, :2]) < 1e-8 * np.linalg.norm(w)
        assert abs(w[s1]) == pytest.approx(abs(w[s2]), rel=1e-8)
        assert abs(w).max() == pytest.approx(1.0)
    assert abs(coriolis.first_mode(model, mass_flow=0.0).phase_difference) < 1e-12


def test_fig8_time_lag_linear_and_density_independent():
    """Fig. 8 (b = 495 mm): the time lag is zero without flow, odd in the flow, positive
    for positive flow (the inlet sensor S1 lags), and linear: dt/mdot at mdot/mdot0 = 0.01
    and 0.02 agree within 1e-3 (measured 1e-5). Sensitivities (fit over 0..0.02):
    water 2.0535e-6 s/(kg/s), kerosene 2.0540e-6 s/(kg/s), relative difference 2.6e-4."""
    b = coriolis.LEG_FIG8
    model = pf.scenes.coriolis_meter(leg_length=b)
    md0 = coriolis.scales(model).mass_flow0
    assert abs(coriolis.time_lag(model, mass_flow=0.0)) < 1e-15
    dt1 = coriolis.time_lag(model, mass_flow=0.01 * md0)
    dt2 = coriolis.time_lag(model, mass_flow=0.02 * md0)
    assert dt1 > 0.0
    assert (dt2 / 0.02) / (dt1 / 0.01) == pytest.approx(1.0, abs=1e-3)
    assert coriolis.time_lag(model, mass_flow=-0.01 * md0) == pytest.approx(-dt1, rel=1e-8)
    f = np.linspace(0.0, 0.02, 5)
    water = coriolis.time_lag_curve(leg_length=b, flows_scaled=f, fluid_density=coriolis.WATER)
    kero = coriolis.time_lag_curve(leg_length=b, flows_scaled=f, fluid_density=coriolis.KEROSENE)
    assert water.nonlinearity < 1e-4 and kero.nonlinearity < 1e-4
    assert water.sensitivity == pytest.approx(2.0535e-6, rel=1e-3)
    assert abs(kero.sensitivity / water.sensitivity - 1.0) < 0.01
    assert water.sensitivity == pytest.approx(coriolis.sensitivity(leg_length=b, flows_scaled=f), rel=1e-12)


@pytest.mark.parametrize("kwargs, name", [
    (dict(leg_length=0.0), "leg_length"),
    (dict(leg_length=-0.3), "leg_length"),
    (dict(leg_length=float("nan")), "leg_length"),
    (dict(leg_length=0.45, fluid_density=float("nan")), "fluid_density"),
    (dict(leg_length=0.45, fluid_density=-1.0), "fluid_density"),
    (dict(leg_length=0.45, radius=0.0), "radius"),
    (dict(leg_length=0.45, arc_elements=0), "arc_elements"),
    (dict(leg_length=0.45, elements_per_leg=1.5), "elements_per_leg"),
    (dict(leg_length=0.45, mass_flow=float("inf")), "mass_flow"),
])
def test_bad_input(kwargs, name):
    with pytest.raises(ValueError, match=name):
        pf.scenes.coriolis_meter(**kwargs)


def test_bad_study_input():
    with pytest.raises(ValueError, match="flows_scaled"):
        coriolis.frequency_curve(leg_length=0.45, flows_scaled=[0.0, float("nan")])
    with pytest.raises(ValueError, match="flows_scaled"):
        coriolis.time_lag_curve(leg_length=0.45, flows_scaled=[0.01])
    with pytest.raises(ValueError, match="fluid"):
        coriolis.scales(pf.scenes.coriolis_meter(leg_length=0.45, fluid_density=0.0))


def test_driven_meter_confirms_complex_mode_time_lag():
    """Drive at the first frequency, process the sensors' zero crossings: the time lag
    equals the complex mode's (measured: 3e-5 relative at mdot/mdot0 = 0.01)."""
    from pipeflex.seeds.seed000 import coriolis

    d = coriolis.driven_time_lag(flow_scaled=0.01, periods=30, ramp_periods=8, measure_periods=8)
    assert d.crossings >= 7
    assert d.time_lag == pytest.approx(d.time_lag_mode, rel=1e-3)
    assert d.time_lag > 0
