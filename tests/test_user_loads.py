"""Loads beyond constants times one load factor: a Python callable of time and the node's
motion (``ModelBuilder.add_load_function``, called by the compiled residual) and a time
function per load (``add_load(time_function=)``: a Sine, a table or a Pulse, in the core)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core

L, N_EL = 2.0, 4  # cantilever length [m], elements
SECTION = pf.PipeSection(EI=40.0, EA=4e5, GJ=30.0, pipe_mass=1.5, fluid_mass=0.5, rotary_inertia=(1e-3, 1e-3, 1e-3))
K, C = 25.0, 0.8  # [N/m], [N s/m]
EPS = np.finfo(float).eps


def cantilever(load=None, *, stiffness=(0.0, 0.0, 0.0), damping=(0.0, 0.0, 0.0), fn=None):
    """A pipe cantilever along x clamped at node 0; at the tip a ground spring-damper and
    either ``load(builder, tip)`` or the load function fn."""
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(root, (L, 0.0, 0.0), N_EL, SECTION)
    b.clamp(root)
    tip = nodes[-1]
    if np.any(stiffness) or np.any(damping):
        b.add_ground_spring(tip, stiffness=stiffness, damping=damping)
    if load is not None:
        load(b, tip)
    if fn is not None:
        b.add_load_function(tip, fn)
    return b.build(), tip


def kicked(model, tip, v=0.3):
    """The reference state with the tip moving at v [m/s] along y."""
    s = model.initial_state()
    vv = np.array(s.v)
    vv[6 * tip + 1] = v
    s.v = vv
    return s


def ulps(a, b, n=16):
    """|a - b| within n ulps of the larger magnitude of the run (two summation orders)."""
    scale = max(np.abs(a).max(), np.abs(b).max())
    return np.abs(a - b).max() <= n * EPS * scale


FORCE = np.array([0.0, 0.7, -0.2])


def constant_force(t, x, v):
    return FORCE, np.zeros(3)


@pytest.mark.parametrize("integrator, options", [("ida", dict(rtol=1e-8, atol=1e-11)),
                                                 ("generalized_alpha", dict(step=2e-3))])
def test_constant_callable_equals_the_builtin_load(integrator, options):
    builtin, tip = cantilever(lambda b, n: b.add_load(n, force=FORCE))
    user, _ = cantilever(fn=constant_force)
    a = pf.simulate(builtin, 0.5, integrator=integrator, n_outputs=51, **options)
    b = pf.simulate(user, 0.5, integrator=integrator, n_outputs=51, **options)
    assert np.abs(a.x[:, tip, 1] - builtin.positions[tip, 1]).max() > 1e-3  # it moves
    assert ulps(a.x, b.x) and ulps(a.xd, b.xd)
    assert ulps(a.load_work, b.load_work, 64)  # the work sees the callable
    assert a.load_work[-1] > 0.0


def test_velocity_proportional_callable_is_a_ground_dashpot():
    dashpot, tip = cantilever(damping=(C, C, C))
    user, _ = cantilever(fn=lambda t, x, v: (-C * np.asarray(v), np.zeros(3)))
    opts = dict(integrator="ida", rtol=1e-9, atol=1e-12, n_outputs=101)
    a = pf.simulate(dashpot, 2.0, state=kicked(dashpot, tip), **opts)
    b = pf.simulate(user, 2.0, state=kicked(user, tip), **opts)
    amp = np.abs(a.x[:, tip, 1]).max()
    assert amp > 1e-3
    assert np.abs(a.x - b.x).max() <= 1e-6 * amp
    # the damping acts: without it the tip's velocity at the end is larger
    free = pf.simulate(cantilever()[0], 2.0, state=kicked(dashpot, tip), **opts)
    assert np.abs(free.x[:, tip, 1] - b.x[:, tip, 1]).max() > 1e-3 * amp


def spring(t, x, v):
    return np.array([0.0, -K * (x[1] - 0.0), 0.0]), np.zeros(3)


def test_position_dependent_callable_is_a_ground_spring():
    builtin, tip = cantilever(lambda b, n: b.add_load(n, force=FORCE), stiffness=(0.0, K, 0.0))
    user, _ = cantilever(lambda b, n: b.add_load(n, force=FORCE), fn=spring)
    ya = pf.static_equilibrium(builtin).state.q[6 * tip + 1]
    yb = pf.static_equilibrium(user).state.q[6 * tip + 1]
    free = pf.static_equilibrium(cantilever(lambda b, n: b.add_load(n, force=FORCE))[0]).state.q[6 * tip + 1]
    assert abs(yb - ya) <= 1e-9 * abs(ya) and abs(free - ya) > 0.1 * abs(ya)
    opts = dict(integrator="ida", rtol=1e-9, atol=1e-12, n_outputs=101)
    a = pf.simulate(builtin, 1.0, state=kicked(builtin, tip), **opts)
    b = pf.simulate(user, 1.0, state=kicked(user, tip), **opts)
    assert np.abs(a.x - b.x).max() <= 1e-6 * np.abs(a.x[:, tip, 1]).max()


def test_the_tangent_is_the_ground_springs():
    """Central differences of fn in position and velocity: K and C equal the spring-damper's
    to the differences' rounding (a zero tangent would leave K without the spring)."""
    k, c = (3.0, K, 7.0), (0.5, C, 0.1)
    builtin, tip = cantilever(stiffness=k, damping=c)
    user, _ = cantilever(fn=lambda t, x, v: (-np.asarray(k) * (np.asarray(x) - builtin.positions[tip])
                                            - np.asarray(c) * np.asarray(v), np.zeros(3)))
    s = kicked(builtin, tip)
    q = np.array(s.q)
    q[6 * tip:6 * tip + 3] += (0.01, -0.02, 0.03)
    s.q = q
    for w in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)):
        ra, (ia, ja, va) = _core.assemble(builtin.core, s, builtin.load_state(), 1.0, *w, True)
        rb, (ib, jb, vb) = _core.assemble(user.core, s, user.load_state(), 1.0, *w, True)
        n = len(ra)
        A = np.zeros((n, n))
        B = np.zeros((n, n))
        np.add.at(A, (ia, ja), va)
        np.add.at(B, (ib, jb), vb)
        assert ulps(ra, rb, 64)
        assert np.abs(A - B).max() <= 1e-8 * max(max(k), max(c))
        assert np.abs(A).max() > 0


def test_an_exception_in_fn_surfaces_with_its_message():
    def broken(t, x, v):
        if t > 0.05:
            raise ZeroDivisionError("the user's message")
        return np.zeros(3), np.zeros(3)

    model, _ = cantilever(fn=broken)
    for integrator in ("ida", "generalized_alpha"):
        with pytest.raises(RuntimeError, match="the user's message") as err:
            pf.simulate(model, 0.2, integrator=integrator)
        text = str(err.value)
        assert "load function broken at node" in text and "ZeroDivisionError" in text
        assert float(text.split("t = ")[1].split(" s")[0]) > 0.05  # the time of the call


@pytest.mark.parametrize("ret, match", [((np.zeros(2), np.zeros(3)), "force must have 3"),
                                        ((np.zeros(3), [0.0, np.nan, 0.0]), r"moment\[1\] is not finite"),
                                        (np.zeros(6), "must return a pair"),
                                        ("abc", "must return a pair")])
def test_bad_returns_are_value_errors_naming_the_load(ret, match):
    def bad(t, x, v):
        return ret

    model, tip = cantilever(fn=bad)
    with pytest.raises(ValueError, match=match) as err:
        pf.static_equilibrium(model)
    assert f"load function bad at node {tip}" in str(err.value)


def test_statics_call_fn_at_time_zero():
    seen = []

    def growing(t, x, v):
        seen.append(t)
        return FORCE * (1.0 + t), np.zeros(3)

    user, tip = cantilever(fn=growing, stiffness=(0.0, K, 0.0))
    builtin, _ = cantilever(lambda b, n: b.add_load(n, force=FORCE), stiffness=(0.0, K, 0.0))
    assert np.allclose(pf.static_equilibrium(user).state.q, pf.static_equilibrium(builtin).state.q,
                       rtol=0.0, atol=1e-12)
    assert seen and set(seen) == {0.0}


def test_bad_builder_input():
    b = pf.ModelBuilder()
    n = b.add_node((0.0, 0.0, 0.0))
    with pytest.raises(TypeError, match="fn must be callable"):
        b.add_load_function(n, 3.0)
    with pytest.raises(ValueError, match="time_function"):
        b.add_load(n, force=(1.0, 0.0, 0.0), time_function="soon")
    with pytest.raises(ValueError, match="duration"):
        b.add_load(n, force=(1.0, 0.0, 0.0), time_function=pf.Pulse(start=0.0, duration=0.0))
    with pytest.raises(ValueError, match="shape"):
        b.add_load(n, force=(1.0, 0.0, 0.0), time_function=pf.Pulse(start=0.0, duration=1.0, shape="square"))


def test_per_load_sine_equals_the_global_load_factor():
    sine = pf.Sine(omega=9.0, envelope=([0.0, 0.2], [0.0, 1.0]), phase=0.3)
    glob, tip = cantilever(lambda b, n: b.add_load(n, force=FORCE))
    per, _ = cantilever(lambda b, n: b.add_load(n, force=FORCE, time_function=sine))
    opts = dict(integrator="ida", rtol=1e-8, atol=1e-11, n_outputs=51)
    a = pf.simulate(glob, 0.6, load_factor=sine, **opts)
    b = pf.simulate(per, 0.6, **opts)
    assert np.abs(a.x[:, tip, 1] - glob.positions[tip, 1]).max() > 1e-4
    assert ulps(a.x, b.x) and ulps(a.load_work, b.load_work, 64)
    # one load timed, another constant: the timed one alone follows the sine
    both, _ = cantilever(lambda b, n: (b.add_load(n, force=FORCE, time_function=sine),
                                       b.add_load(n, force=-FORCE)))
    s = both.initial_state()
    f = _core.external_forces(both.core, s, 0.35)
    assert np.allclose(f[6 * tip:6 * tip + 3], FORCE * (np.sin(9.0 * 0.35 + 0.3) - 1.0), rtol=1e-14, atol=0.0)


@pytest.mark.parametrize("shape", ["half_sine", "rectangle"])
def test_pulse_momentum_change_is_the_impulse(shape):
    m, F, d = 2.0, 3.0, 0.05  # [kg], [N], [s]
    pulse = pf.Pulse(start=0.02, duration=d, shape=shape)
    b = pf.ModelBuilder()
    n = b.add_node((0.0, 0.0, 0.0))
    b.add_point_mass(n, m, (1e-3, 1e-3, 1e-3))
    b.add_ground_spring(n, stiffness=(0.0, 1.0, 0.0))  # along the fixed y: a free mass along x
    b.fix(n, ["uy", "uz", "rx", "ry", "rz"])
    b.add_load(n, force=(F, 0.0, 0.0), time_function=pulse)
    model = b.build()
    # fixed steps h that end on the pulse's ends; with rho_inf = 1 a step averages the
    # force at its two ends (the trapezoidal rule): error (pi h / d)^2 / 12 of the half
    # sine, and h / d of the rectangle (its ends sampled at 0)
    h = 1e-3
    res = pf.simulate(model, 0.2, integrator="generalized_alpha", step=h, rho_inf=1.0, n_outputs=201)
    t, v = res.t, res.xd[:, n, 0]
    assert np.abs(v[t <= 0.02 - 1e-9]).max() == 0.0  # nothing before the pulse
    expected = F * pulse.integral / m
    tol = (np.pi * h / d) ** 2 / 12 if shape == "half_sine" else h / d
    after = v[t >= 0.02 + d + 1e-9]
    assert np.abs(after - expected).max() <= 1.01 * tol * expected
    if shape == "half_sine":  # continuous: IDA resolves it to its tolerance
        res = pf.simulate(model, 0.2, integrator="ida", rtol=1e-9, atol=1e-12, n_outputs=201)
        assert np.abs(res.xd[res.t >= 0.02 + d + 1e-9, n, 0] - expected).max() <= 1e-6 * expected
    assert pulse.integral == pytest.approx(d if shape == "rectangle" else 2 * d / np.pi, rel=1e-15)


def test_models_with_load_functions_cannot_be_saved(tmp_path):
    """A callable has no file form: saving refuses it by name; a per-load time function
    (a Sine) is saved and loads back to the same external forces."""
    model, _ = cantilever(fn=spring)
    with pytest.raises(ValueError, match="load function spring .*cannot be saved"):
        pf.save_model(model, tmp_path / "m.yaml")
    timed, _ = cantilever(lambda b, n: b.add_load(n, force=FORCE, time_function=pf.Sine(omega=2.0)))
    pf.save_model(timed, tmp_path / "t.yaml")
    other = pf.load_model(tmp_path / "t.yaml")
    s = timed.initial_state()
    for t in (0.1, 0.7):
        assert np.array_equal(_core.external_forces(timed.core, s, t), _core.external_forces(other.core, s, t))
    assert np.abs(_core.external_forces(timed.core, s, 0.7)).max() > 0.0


def test_models_with_timed_and_function_loads_pickle():
    import pickle

    for model in (cantilever(fn=spring)[0],
                  cantilever(lambda b, n: b.add_load(n, force=FORCE, time_function=pf.Pulse(0.0, 0.1)))[0]):
        other = pickle.loads(pickle.dumps(model))
        s = model.initial_state()
        q = np.array(s.q)
        q[-5] = 0.01  # the tip off its reference position along y: the spring pulls back
        s.q = q
        assert np.array_equal(_core.external_forces(model.core, s, 0.05), _core.external_forces(other.core, s, 0.05))
        assert np.abs(_core.external_forces(model.core, s, 0.05)).max() > 0.2


def test_an_ancf_node_takes_the_function_force_and_refuses_a_moment():
    P = 1e-4  # [N]
    sec = pf.PipeSection(EI=10.0, EA=1e5, pipe_mass=1.0)
    for fn, ok in ((lambda t, x, v: ((0.0, P, 0.0), (0.0, 0.0, 0.0)), True),
                   (lambda t, x, v: ((0.0, P, 0.0), (0.0, 0.0, 1.0)), False)):
        b = pf.ModelBuilder()
        nodes = b.add_ancf_beam((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 4, sec)
        b.clamp(nodes[0])
        b.add_load_function(nodes[-1], fn, name="tip_load")
        if ok:
            y = pf.static_equilibrium(b.build()).state.q[6 * nodes[-1] + 1]
            assert y == pytest.approx(P / (3.0 * 10.0), rel=1e-6)  # P L^3 / (3 EI)
        else:
            with pytest.raises(ValueError, match="tip_load at node 4 returned a moment at t = 0 s: an ANCF node"):
                pf.static_equilibrium(b.build())
