"""Seed 004 scenes: the FFRF cantilever, curved pipe and concrete printer."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import scenes
from pipeflex.seeds.seed000 import references as ref000, validation as val000
from pipeflex.seeds.seed004 import references as ref004, studies as fs, validation as val004
from pipeflex.multibody import MultibodyBuilder, flexible_body, linearize, simulate, static_equilibrium

from conftest import FAST


@pytest.mark.parametrize("n_bodies", [1, 2])
def test_n_bodies_reproduce_table2_with_2n_elements(n_bodies):
    """Seed 000, Table 2 (2 and 4 elements: 24.962732, 25.054732 kg/s) from 1 and 2 FFRF
    bodies with boundary modes: a body with its centre node fixed is two Hermite elements."""
    m = pf.critical_mass_flow(scenes.ffrf_cantilever_pipe(n_bodies=n_bodies, elements_per_body=50)).mass_flow
    assert m == pytest.approx(ref000.TABLE2[2 * n_bodies], rel=val000.TOL_TABLE2)


def test_internal_modes_converge_faster_per_state_size():
    """Seed 004, Fig. 7: one body with internal modes approaches the converged critical
    flow with a smaller state vector than more bodies without."""
    d = fs.critical_flow_vs_state_size(bodies=(1, 2, 4), modes=(0, 8, 16))
    ref = ref000.TABLE2_EXTRAPOLATED
    err_b = np.abs(d["bodies_flow"] - ref)
    err_m = np.abs(d["modes_flow"] - ref)
    assert err_b[2] < err_b[1] and err_m[-1] < err_m[0]  # (Table 2 is not monotone from 2 to 4 elements)
    # 16 internal modes (state 56) beat 2 bodies (state 48) and match 4 bodies (state 96)
    assert d["modes_size"][-1] < d["bodies_size"][-1]
    assert err_m[-1] < err_b[1] and err_m[-1] < 1.5 * err_b[-1]


def test_curved_pipe_is_assembled_on_the_semicircle():
    s = scenes.ffrf_curved_pipe(E=9.585e9)
    st = s.initial_state()
    c, _ = s.constraints(st)
    assert np.abs(c).max() < 1e-12
    pts = np.vstack(s.centre_line(st))
    r = np.linalg.norm(pts[:, [0, 2]] - np.array([0.5, 0.0]), axis=1)
    assert np.abs(pts[:, 1]).max() < 1e-12
    # body end nodes exactly on the arc; interior nodes follow the cubic constraint modes
    ends = np.vstack([p[[0, -1]] for p in s.centre_line(st)])
    assert np.linalg.norm(ends[:, [0, 2]] - np.array([0.5, 0.0]), axis=1) == pytest.approx(0.5, abs=1e-12)
    assert np.abs(r - 0.5).max() < 2e-4


@pytest.mark.parametrize("E", sorted(ref004.TABLE1_FFRF))
def test_curved_pipe_table1(E):
    """Seed 004, Table 1, FFRF column (5.320, 9.117, 9.954 rad/s): within 1%."""
    _, res, w = fs.curved_pipe_run(E, t_end=3.0 if FAST else 4.0, n_outputs=301)
    assert fs.final_angular_velocity(res.t, w) == pytest.approx(ref004.TABLE1_FFRF[E], rel=val004.TOL_TABLE1)
    assert res.drift.max() < 1e-3


def test_energy_is_conserved_without_flow():
    """A deflected FFRF cantilever released without flow (rho_inf = 0.99: little numerical
    damping) keeps its energy; the position constraints hold and their velocity drift is
    small."""
    loaded = scenes.ffrf_cantilever_pipe(n_bodies=2, tip_force=1.5)
    free = scenes.ffrf_cantilever_pipe(n_bodies=2)
    st = static_equilibrium(loaded, mass_flow=0.0).state
    res = simulate(free, 1.0, step=5e-4, state=st, mass_flow=0.0, rho_inf=0.99, n_outputs=11)
    E = np.array([free.energy(res.state(k)) for k in range(len(res.t))])
    assert np.abs(E - E[0]).max() < 1e-4 * E[0]
    assert res.drift.max() < 1e-3 * np.abs(res.v).max()


def test_one_body_flutters_without_bound():
    """Where the method fails: a single body (clamped, frame at its centre) is linear in its
    elastic coordinates, so above the critical flow its tip grows exponentially instead of
    settling into the limit cycle: it starts as the linearised flutter predicts (an
    oscillation growing at the unstable eigenvalue's rate) and ends far away (the run
    stops when the body is 1000 lengths from its start: "the motion diverged")."""
    tr = fs.ffrf_cantilever_tip(n_bodies=1, t_end=3.0, n_outputs=601, until_failure=True)
    s = scenes.ffrf_cantilever_pipe(n_bodies=1, tip_force=1.5)
    lam = pf.eigenvalues(linearize(s, static_equilibrium(s, mass_flow=0.0).state, mass_flow=30.0)).values
    crossing = lam[lam.real > 0]
    assert len(crossing) and np.all(np.abs(crossing.imag) > 1.0)  # flutter, not divergence
    assert np.abs(tr.y).max() > 5.0  # metres: no limit cycle


def test_two_bodies_reach_the_limit_cycle():
    """Seed 004, Fig. 4: with more than one body the flutter saturates (0.38 m with 2 bodies,
    0.42 m with 8 bodies and with the seed-000 element)."""
    tr = fs.ffrf_cantilever_tip(n_bodies=2, t_end=3.0, n_outputs=601)
    c = fs.cycle_summary(tr, after=2.0)
    assert 0.3 < c["amplitude"] < 0.5
    assert c["period"] == pytest.approx(0.44, rel=0.03)


def test_eight_bodies_match_the_eight_element_model():
    """Seed 004, Fig. 4: with as many elastic coordinates per length as seed 000's 8
    elements have, 8 FFRF bodies settle into the same limit cycle (docs/validation.md:
    amplitude 0.424 against 0.422 m, period within 0.3 %)."""
    ffrf = fs.cycle_summary(fs.ffrf_cantilever_tip(n_bodies=8, t_end=3.0, n_outputs=601), after=2.0)
    element = fs.cycle_summary(fs.element_cantilever_tip(n_elements=8, t_end=3.0, n_outputs=601), after=2.0)
    assert ffrf["amplitude"] == pytest.approx(element["amplitude"], rel=0.01)
    assert ffrf["period"] == pytest.approx(element["period"], rel=0.01)


def test_printer_flow_moves_the_nozzle():
    """Seed 004, sec. 8.3: the nozzle stays at the roller's height; the concrete flow
    changes its path, more at 6 m/s than at 3 m/s."""
    step = 5e-4 if FAST else 2e-4
    paths = {v: fs.printer_run(v, step=step)[2] for v in fs.PRINTER_FLOW_SPEEDS}
    for p in paths.values():
        assert np.abs(p[:, 2] - p[0, 2]).max() < 1e-8
        assert np.ptp(p[:, 1]) > 0.05  # the arm swings about z
    shift = fs.nozzle_shift(paths)
    assert 0.0 < shift[3.0] < shift[6.0] < 0.05


def test_printer_statics():
    s = scenes.concrete_printer(flow_speed=6.0)
    st = static_equilibrium(s, load_steps=4)
    assert st.residual < 1e-8 * 5000
    c, _ = s.constraints(st.state)
    assert np.abs(c).max() < 1e-10
    # the moment at A is carried by the tension of CD: its hinge and the roller take it
    assert np.abs(st.state.lam).max() > 1e3


def test_critical_flow_converges_at_fourth_order_in_bodies():
    """Errors against seed 000's extrapolated 25.005520 kg/s fall as (size)^-4, as for
    Hermite elements (2, 4, 8 bodies = 4, 8, 16 elements)."""
    d = fs.critical_flow_vs_state_size(bodies=(2, 4, 8), modes=())
    err = np.abs(d["bodies_flow"] - ref000.TABLE2_EXTRAPOLATED)
    order = np.log2(err[:-1] / err[1:])
    assert np.all(order > 3.5)


def test_unreduced_body_equals_the_element_mesh():
    """One body without reduction (every node but the centre) is the plain FE mesh:
    its critical flow equals seed 000's element with as many elements."""
    s = scenes.ffrf_cantilever_pipe(n_bodies=1, elements_per_body=6, reduction="full")
    ref = pf.critical_mass_flow(scenes.cantilever_pipe(n_elements=6)).mass_flow
    assert pf.critical_mass_flow(s).mass_flow == pytest.approx(ref, rel=1e-9)


def test_second_branch_crosses_at_the_critical_speed():
    """Seed 004, Fig. 6: the Hopf bifurcation is the second bending branch crossing the
    imaginary axis, at sdot_cr = 12.50 m/s (25.0055 kg/s / 2 kg/m)."""
    c = fs.eigenvalue_curves([0.0, 6.0, 12.0, 13.0])
    assert np.all(c[:, 0].real <= 1e-9) and np.all(c[:, 2:].real <= 1e-9)
    assert c[2, 1].real < 0 < c[3, 1].real
    assert c[0, :2].imag == pytest.approx([3.516, 22.035], abs=1e-3)  # cantilever: 1.875^2, 4.694^2 sqrt(EI/m)


def _spinning(system, omega):
    st = system.initial_state()
    for j in range(len(system.bodies)):
        o = system.offsets[j]
        st.v[o:o + 3] = np.cross(omega, st.r[j])
        st.v[o + 3:o + 6] = omega
    return st


def test_spinning_body_keeps_energy_and_angular_momentum():
    """A straight body on a hinge, spinning at 5 rad/s without flow: energy and the speed
    about the hinge stay (rotation terms of the body kernel, Lie-group integration)."""
    sec = pf.PipeSection.tube(outer_diameter=0.0368, inner_diameter=0.03568, E=95.85e9, G=36.9e9, density=7870.0,
                              rotary_inertia=True)
    body = flexible_body(length=0.4, n_elements=4, section=sec)
    b = MultibodyBuilder()
    b.hinge(b.add_body(body, position=(0.2, 0.0, 0.0)), "start", (0.0, 0.0, 1.0))
    s = b.build()
    res = simulate(s, 1.0, step=2.5e-4, state=_spinning(s, np.array([0.0, 0.0, 5.0])), rho_inf=0.95, n_outputs=11)
    E = np.array([s.energy(res.state(k)) for k in range(len(res.t))])
    assert np.abs(E - E[0]).max() < 5e-5 * E[0]
    assert res.angular_velocity(0)[:, 2] == pytest.approx(5.0, rel=1e-3)
    assert np.abs(res.r[:, 0]).max() < 0.2 + 1e-3  # turned about the hinge: |r| stays L/2


def test_spinning_curved_pipe_keeps_its_energy_with_little_damping():
    """The semicircular FFRF pipe (straight bodies, preimposed curvature) spinning freely at
    5 rad/s keeps its energy to 1e-4 with the default rho_inf = 0.8 and with little
    numerical damping (0.95). The earlier multibody integrator, which composed every
    Newton correction into the frames (R <- exp(dq~) R per iteration) instead of the
    step's one increment, diverged at 0.95 here."""
    s = scenes.ffrf_curved_pipe(E=95.85e9, n_bodies=4, elements_per_body=4, flow_speed=0.0)
    spin = _spinning(s, np.array([0.0, 5.0, 0.0]))
    for rho in (0.8, 0.95):
        res = simulate(s, 2.0, step=1e-3, state=spin, n_outputs=11, rho_inf=rho)
        E = np.array([s.energy(res.state(k)) for k in range(len(res.t))])
        assert np.abs(E - E[0]).max() < 2e-4 * E[0]
        assert res.stats["convergence_failures"] == 0


@pytest.mark.slow
def test_32_bodies_equal_64_elements():
    """Seed 004, Fig. 7's finest chain: 32 bodies (51 nodes each) against seed 000's
    element with 64 elements (beyond Table 2), and both against Table 2's extrapolation."""
    m = pf.critical_mass_flow(scenes.ffrf_cantilever_pipe(n_bodies=32, elements_per_body=50)).mass_flow
    ref = pf.critical_mass_flow(scenes.cantilever_pipe(n_elements=64)).mass_flow
    assert m == pytest.approx(ref, rel=1e-8)
    assert m == pytest.approx(ref000.TABLE2_EXTRAPOLATED, rel=val000.TOL_TABLE2_EXTRAPOLATED)


def test_a_chain_of_many_short_bodies_is_as_large_as_the_chain():
    """The Newton tests' scale is the assembly's extent, not the longest body: a 192-body
    cantilever (5.2 mm bodies) deflects 75 mm in its first Newton correction, which the
    body length's divergence limit (10 body lengths) would take for a singular tangent
    (and fall back to the dense null-space step, 37 s); it stays on the sparse KKT Newton,
    a tenth of a second. The constraint check at build is sparse too."""
    s = pf.scenes.ffrf_cantilever_pipe(n_bodies=192, elements_per_body=4, tip_force=1.5)
    assert s.length_scale == pytest.approx(1.0, rel=1e-12)  # the 1 m cantilever
    assert s.length_scale > 100 * max(b.length for b in s.bodies)
    system = s.system()
    out = pf._core.static_equilibrium(system, 0.0, 1.0, 1e-10, 30)
    assert out["converged"] and not out["diverged"] and out["iterations"] <= 6
    res = pf.multibody.static_equilibrium(s, mass_flow=0.0)
    r, R, eta, _, _, lam, _ = system.body_state
    assert np.allclose(res.state.eta, eta, rtol=0, atol=1e-12)
