"""Joints, driving torques and time-function loads of the floating-frame bodies against
hand calculations (Euler-Bernoulli beam formulas, rigid-body dynamics)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import scenes
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


# -- mechanisms in the core's static Newton ---------------------------------------------

def _hinged_chain(n, clamp=False, gravity=(0.0, 0.0, -9.81), axis=(0.0, 0.0, 1.0), EA=1e8):
    """n bodies rigidly joined along x (4 m), the first on a ground hinge about ``axis``
    (default z; or clamped); gravity along -z leaves a hinge about z unloaded. EA = 1e3 EI
    (None: the default, 1e10 EI)."""
    sec = pf.PipeSection(EI=1e5, pipe_mass=8.0, fluid_mass=2.0, **({} if EA is None else {"EA": EA}))
    body = flexible_body(length=4.0 / n, n_elements=4, section=sec)
    b = MultibodyBuilder()
    ids = [b.add_body(body, position=(4.0 / n * (k + 0.5), 0.0, 0.0)) for k in range(n)]
    if clamp:
        b.fix(ids[0], "start")
    else:
        b.hinge(ids[0], "start", axis)
    for k in range(n - 1):
        b.rigid(ids[k], "end", ids[k + 1], "start")
    b.set_gravity(gravity)
    return b.build()


def test_free_hinge_keeps_its_assembly_angle_and_the_clamped_equilibrium():
    """The hinge's free rotation (a mechanism: the core's Newton with its penalty and
    filter, no dense step) is left at its assembly value: the chain sags in the x-z plane
    as if clamped (the clamp takes no moment about z). Measured: 3 iterations (the clamped
    chain's plain KKT Newton and the old dense null-space step: 3); the frames within
    2e-15 m of the clamped chain's (tip sag 2.9 cm), y exactly 0."""
    hinged = static_equilibrium(_hinged_chain(8))
    clamped = static_equilibrium(_hinged_chain(8, clamp=True))
    assert hinged.iterations <= 5
    for j in range(8):
        np.testing.assert_allclose(hinged.state.r[j], clamped.state.r[j], atol=1e-10)
    assert np.abs(np.array(hinged.state.r)[:, 1]).max() < 1e-12
    assert clamped.state.r[7][2] < -1e-4  # it does sag


def _spherical_chain(n):
    """n bodies of 0.5 m (EI 1e4 N m^2, 10 kg/m) between two clamps joined by spherical
    joints, gravity along -z: each inner body's spin about its chord is free, and so are,
    to first order, the joints' motions across the straight chain (stiff only through the
    tension the sag brings)."""
    sec = pf.PipeSection(EI=1e4, pipe_mass=8.0, fluid_mass=2.0)
    body = flexible_body(length=0.5, n_elements=4, section=sec)
    b = MultibodyBuilder()
    ids = [b.add_body(body, position=(0.5 * k + 0.25, 0.0, 0.0)) for k in range(n)]
    b.fix(ids[0], "start")
    for k in range(n - 1):
        b.spherical(ids[k], "end", ids[k + 1], "start")
    b.fix(ids[-1], "end")
    b.set_gravity((0.0, 0.0, -9.81))
    return b.build()


def test_spherical_chain_converges_through_the_core():
    """Four bodies between two clamps joined by spherical joints. The core's Newton leaves
    the spins alone and reaches the old dense null-space step's sag at the middle joint
    (-1.036424436952846e-4 m, its result then) to 1e-10 model sizes, in 10 iterations (18
    with the dense step, 14 with the penalty's first filter alone)."""
    system = _spherical_chain(4)
    st = static_equilibrium(system)
    assert st.iterations <= 12
    mid = system.node_position(st.state, 1, "end")
    assert mid[2] == pytest.approx(-1.036424436952846e-4, abs=1e-10 * system.length_scale)
    assert abs(mid[1]) < 1e-10


def test_eight_body_spherical_chain_converges():
    """Eight such bodies (4 m): the inner bodies' motions across the chain in its vertical
    plane (z and the rotation about y; their stiffness is the sag's tension, about 3 times
    the penalty) converged at 0.65 per iteration under the penalty's filter, the stall test
    took that for round-off after 15 iterations and the driven check refused the state with
    1.28e-3 N on them (2.6e-5 of the applied level). Once the force on the free motions has
    fallen below 1e-3 of the force level the filter's solves are combined into a steeper
    step (rate 0.24 here): 15 iterations, 9e-7 N left on the free motions. The sag of
    a tight tolerance (19 iterations) to 1e-10 model sizes, symmetric about the middle
    joint; the spins and every motion out of the plane keep their assembly value exactly."""
    system = _spherical_chain(8)
    res = static_equilibrium(system)
    assert res.iterations <= 18
    st = res.state
    z = [system.node_position(st, j, "end")[2] for j in range(7)]
    assert z[3] == pytest.approx(-4.08207140646064e-4, abs=1e-10 * system.length_scale)
    np.testing.assert_allclose(z[:3], z[-1:-4:-1], atol=1e-15)
    assert np.abs(np.array(st.r)[:, 1]).max() == 0.0
    R = np.array(st.R)
    assert np.abs(R[:, 0, 1]).max() == 0.0 and np.abs(R[:, 1, 2]).max() == 0.0  # no spin, no turn about z
    free = system.core.free_motions(st.r, st.R, st.eta, st.lam, 0.0, 0.0)
    assert np.abs(free["force"]).max() < 1e-7 * 49.05  # of the applied level (a body's weight): 1.8e-8


def test_driven_spherical_chain_is_not_walked_to_a_far_equilibrium():
    """The fuzz's case 220 (seed 0, 300 multibody cases): three soft bodies (EI 1 N m^2) on
    spherical joints from a clamp, a tip load across them; it drives the joints (0.29 of the
    applied level). With the mechanism's fast filter gated only by the force on the free
    motions, the safe filter would walk the chain round until that force had fallen, the
    fast one would finish the walk within 30 iterations and return the last body's frame
    turned by more than a radian; the fast filter is used only while the frames stay near
    the solve's start, so the load is refused as driving the mechanism."""
    sec = pf.PipeSection(EI=1.0, GJ=1.0, pipe_mass=1.0, fluid_mass=1.0)
    length = 0.4641588833612779
    body = flexible_body(length=length, n_elements=6, section=sec, internal_modes=1)
    d = np.array([0.0, -1.0 / 3.0, 0.16490636717560173])
    d /= np.linalg.norm(d)
    b = MultibodyBuilder()
    for j in range(3):
        b.add_body_between(body, j * length * d, (j + 1) * length * d)
    b.fix(0, "start")
    b.spherical(0, "end", 1, "start")
    b.spherical(1, "end", 2, "start")
    b.add_load(2, "end", force=(-4.151907, -1.547161, 0.0))
    with pytest.raises(pf.SingularMatrixError, match=r"the loads drive a mechanism"):
        static_equilibrium(b.build())


def test_driven_hinge_raises_the_mechanism_error():
    """Gravity in the hinge's plane swings the chain: no equilibrium near the assembly;
    the residual check names the mechanism."""
    with pytest.raises(pf.SingularMatrixError, match=r"residual .* of the applied force level .*mechanism"):
        static_equilibrium(_hinged_chain(4, gravity=(0.0, -9.81, 0.0)))


@pytest.mark.parametrize("n", [2, 3, 4])
def test_weight_turning_a_hinge_raises_with_nearly_inextensible_bodies(n):
    """A ground hinge about the horizontal y axis, gravity along -z: the weight turns the
    chain, there is no equilibrium near the assembly. With the default EA (1e10 EI) the
    old check (the residual against 1e3 eps |S|_max L, the axial stiffness' round-off)
    let it return with a residual of 110 N (4 bodies) and no error. The residual's
    generalised force on the free rotation is 0.38 of the applied force level."""
    with pytest.raises(pf.SingularMatrixError, match=r"residual along the rigid motions .* of the applied force "
                                                     r"level .*the loads drive a mechanism"):
        static_equilibrium(_hinged_chain(n, axis=(0.0, 1.0, 0.0), EA=None))


@pytest.mark.parametrize("n", [2, 3, 4])
def test_unloaded_vertical_hinge_converges_with_nearly_inextensible_bodies(n):
    """The same chains on a hinge about the vertical z axis: the weight does no work on
    its rotation, the chain sags as if clamped (the generalised force on the free rotation
    at the result: 1e-22 N)."""
    hinged = static_equilibrium(_hinged_chain(n, EA=None))
    clamped = static_equilibrium(_hinged_chain(n, clamp=True, EA=None))
    for j in range(n):
        np.testing.assert_allclose(hinged.state.r[j], clamped.state.r[j], atol=1e-10)
    assert clamped.state.r[-1][2] < -1e-2


def test_flow_turning_a_bent_pipe_on_a_hinge_raises():
    """Seed 004's curved pipe on its hinge about z: at rest an equilibrium; with flow the
    jet's reaction at the bent end turns it (a sprinkler), no static equilibrium."""
    system = scenes.ffrf_curved_pipe(E=9.585e9, n_bodies=2, elements_per_body=4)
    assert static_equilibrium(system, mass_flow=0.0).residual < 1e-12
    with pytest.raises(pf.SingularMatrixError, match=r"the loads drive a mechanism"):
        static_equilibrium(system, mass_flow=0.5)


def test_failed_load_step_is_halved():
    """Clamped body, a tip force that bends it by 17 % of its length: Newton does not
    converge in 3 iterations from the assembly; halved steps (the one continuation,
    max_bisections as pf.static_equilibrium's) reach the one-step result with 30."""
    b = MultibodyBuilder()
    j = b.add_body(_body(), position=(L / 2, 0.0, 0.0))
    b.fix(j, "start")
    b.add_load(j, "end", force=(0.0, 40.0, 0.0))
    s = b.build()
    with pytest.raises(pf.ConvergenceError, match="did not converge at load factor 1 "):
        static_equilibrium(s, max_iterations=3, max_bisections=0, path="load")
    halved = static_equilibrium(s, max_iterations=3)
    whole = static_equilibrium(s)
    np.testing.assert_allclose(s.node_position(halved.state, j, "end"), s.node_position(whole.state, j, "end"),
                               atol=1e-9 * L)
    for solve in (static_equilibrium, pf.static_equilibrium):  # the latter passes it on
        with pytest.raises(ValueError, match="max_bisections"):
            solve(s, max_bisections=-1)
