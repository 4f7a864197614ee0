"""Joints, driving torques and time-function loads of the floating-frame bodies against
hand calculations (Euler-Bernoulli beam formulas, rigid-body dynamics)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.multibody import MultibodyBuilder, flexible_body, simulate, static_equilibrium

L, EI, MU = 0.8, 50.0, 2.0  # m, N m^2, kg/m
SECTION = pf.PipeSection(EI=EI, pipe_mass=MU)


def _body(n_elements=4):
    return flexible_body(length=L, n_elements=n_elements, section=SECTION)


def test_hinge_torque_spins_the_body_up():
    """A stiff body on a ground hinge about +z under a constant torque T [N m]: omega_z = T t
    / I with I = mu L^3 / 3 about the hinge (T positive about the axis turns body a
    positively). The frame's centre stays on the circle of radius L/2."""
    b = MultibodyBuilder()
    j = b.add_body(flexible_body(length=L, n_elements=4, section=pf.PipeSection(EI=1e6, pipe_mass=MU)),
                   position=(L / 2, 0.0, 0.0))
    T = 0.3
    b.hinge(j, "start", (0.0, 0.0, 1.0), torque=T)
    s = b.build()
    res = simulate(s, 0.2, step=1e-3, n_outputs=5, rho_inf=0.8)
    inertia = MU * L**3 / 3
    assert res.angular_velocity(0)[:, 2] == pytest.approx(T * res.t / inertia, rel=1e-4, abs=1e-9)
    assert np.linalg.norm(res.r[:, 0], axis=1) == pytest.approx(L / 2, rel=1e-6)


def test_time_table_tip_load_bends_the_clamped_body():
    """Clamped at its start, a tip force given as a ramp table (0 -> 2 mN over 1 s): at t the
    static deflection is F(t) L^3 / (3 EI) (the body's cubic shapes are exact for end loads).
    With the default EA = 1e10 EI the bending stiffness is ~1e-10 of the largest: the static
    solver once dropped it as a neutral direction and returned 6 % of this deflection."""
    b = MultibodyBuilder()
    j = b.add_body(_body(), position=(L / 2, 0.0, 0.0))
    b.fix(j, "start")
    b.add_load(j, "end", force=(0.0, ([0.0, 1.0], [0.0, 2e-3]), 0.0))
    s = b.build()
    for t in (0.25, 0.5):
        st = static_equilibrium(s, t=t).state
        expected = 2e-3 * t * L**3 / (3 * EI)
        assert s.node_position(st, j, "end")[1] == pytest.approx(expected, rel=1e-5)


def test_hinge_and_roller_make_a_simply_supported_beam():
    """Hinge (about z) at one end, roller (no motion along y) at the other, force F along -y
    at mid-span: the roller carries F / 2 (its multiplier), the centre deflects by
    F L^3 / (48 EI) and the roller end does not move along y."""
    b = MultibodyBuilder()
    j = b.add_body(_body(), position=(L / 2, 0.0, 0.0))
    b.hinge(j, "start", (0.0, 0.0, 1.0))  # out of the x-y plane the body is a cantilever
    b.roller(j, "end", (0.0, 1.0, 0.0))
    F = 1e-3
    b.add_load(j, "center", force=(0.0, -F, 0.0))
    s = b.build()
    st = static_equilibrium(s).state
    assert s.node_position(st, j, "center")[1] == pytest.approx(-F * L**3 / (48 * EI), rel=1e-5)
    assert s.node_position(st, j, "end")[1] == pytest.approx(0.0, abs=1e-14)
    assert np.abs(st.lam[-1]) == pytest.approx(F / 2, rel=1e-6)
