"""Property-based tests, a fast deterministic slice of
``make fuzz`` (tests/fuzz/): hypothesis draws models through the public builder and the
analyses, with a fixed number of examples and derandomised (the same examples on every
run, so CI is deterministic; the "ci" profile of conftest.py).

* random valid models (static, eigen, critical flow, simulate with both integrators,
  ANCF, multibody) give finite results or a documented exception (ValueError,
  TypeError, ConvergenceError and its SingularMatrixError);
* random invalid inputs give ValueError or TypeError naming the parameter;
* invariants at random states: rigid motion gives no elastic force (pipe element, FFRF
  body); a uniform translation's kinetic energy is the total mass (sections and point
  masses); the energy balance holds without flow (generalised-alpha, rho_inf = 1, and
  the multibody integrator).
"""
import math
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import pipeflex as pf
from pipeflex import _core

sys.path.insert(0, str(Path(__file__).parent / "fuzz"))
import models  # noqa: E402  (tests/fuzz/models.py: the strategies of make fuzz)

# deadline=None: the machine is shared and timings vary; hangs are the fuzz driver's
# business (a watchdog per case) and pytest-timeout's.
FAST = settings(max_examples=25, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck))
MODELS = settings(FAST, max_examples=40)
INPUTS = settings(FAST, max_examples=60)

# Open bugs found by the fuzz in files of other areas, reported with reproducers (see
# docs/errors.md, "Fuzzing and sanitizers"): met here, they warn instead of failing, so
# that a new kind of failure still fails. Remove an entry when its fix lands.
KNOWN_OPEN: list = []


def _check(case):
    try:
        return models.run_case(case)
    except models.Bug as e:
        if any(re.search(p, str(e)) for p in KNOWN_OPEN):
            warnings.warn(f"known open bug: {e}; case {models.dumps(case)}")
            return "known"
        raise AssertionError(f"{e}\ncase: {models.dumps(case)}") from e


# -- 1. random valid models: finite results or documented errors -----------------------

@pytest.mark.parametrize("family", models.FAMILIES)
def test_valid_models_give_finite_results_or_documented_errors(family):
    outcomes = []

    @MODELS
    @given(models.cases(family))
    def run(case):
        outcomes.append(_check(case))

    run()
    assert len(outcomes) == MODELS.max_examples
    assert "ok" in outcomes, outcomes  # the strategies mostly make solvable models


# -- 2. random invalid inputs: ValueError / TypeError naming the parameter -------------

BAD_NUMBERS = st.sampled_from([-1.0, 0.0, -1e-300, math.nan, math.inf, -math.inf, 1e300, "abc", None, [1.0, 2.0]])
SECTION_FIELDS = ["EI", "pipe_mass", "fluid_mass", "EIz", "EA", "GJ", "GAy", "GAz", "kv"]


def _refused(call, name):
    with pytest.raises((ValueError, TypeError)) as info:
        call()
    assert name in str(info.value), f"{type(info.value).__name__}: {info.value} (should name {name!r})"


def _valid(field, value):
    """The few of BAD_NUMBERS a field accepts: None (the default) for the optional
    stiffnesses, 0 for one of the two masses (the other is > 0)."""
    return (value is None and field in ("EIz", "EA", "GJ", "GAy", "GAz")) or \
        (value == 0.0 and field in ("pipe_mass", "fluid_mass"))


@INPUTS
@given(field=st.sampled_from(SECTION_FIELDS), value=BAD_NUMBERS)
def test_bad_section_field_is_named(field, value):
    assume(not _valid(field, value))
    _refused(lambda: pf.PipeSection(**{"EI": 1.0, "pipe_mass": 1.0, "fluid_mass": 0.5, field: value}), field)


@INPUTS
@given(value=st.sampled_from([(0.0, 0.0), (0.0, math.nan, 0.0), (0.0, 0.0, math.inf), "abc", None, 3.0,
                              (0.0, 0.0, 0.0, 0.0), (1e300, 0.0, 0.0)]))
def test_bad_position_is_named(value):
    b = pf.ModelBuilder()
    if isinstance(value, tuple) and len(value) == 3 and abs(value[0]) == 1e300:
        b.add_node(value)  # large but finite: accepted
        return
    _refused(lambda: b.add_node(value), "position")


BUILDER_CALLS = {
    "n_elements": lambda b, n, sec, v: b.add_line(n, (1.0, 0.0, 0.0), v, sec),
    "angle": lambda b, n, sec, v: b.add_arc(n, center=(0.0, 1.0, 0.0), angle=v, normal=(0, 0, 1), n_elements=2,
                                            section=sec),
    "gravity": lambda b, n, sec, v: b.set_gravity(v),
    "force": lambda b, n, sec, v: b.add_load(n, force=v),
    "moment": lambda b, n, sec, v: b.add_load(n, moment=v),
    "mass": lambda b, n, sec, v: b.add_point_mass(n, v),
    "axis": lambda b, n, sec, v: b.hinge(n, v),
    "normal": lambda b, n, sec, v: b.add_arc(n, center=(0.0, 1.0, 0.0), angle=1.0, normal=v, n_elements=2,
                                             section=sec),
    "mass_flow": lambda b, n, sec, v: (b.add_line(n, (1.0, 0.0, 0.0), 2, sec), b.clamp(n), b.build(mass_flow=v)),
}
BAD = {
    "n_elements": [0, -3, 2.5, "2", None, math.nan, 10**9],
    "angle": [0.0, math.nan, math.inf, 7.0, -100.0, "1"],
    "gravity": [(0.0, 0.0), (0.0, 0.0, math.nan), (0.0, 0.0, 1e7), "g", None],
    "force": [(0.0, 0.0), (math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), "f"],
    "moment": [(0.0,), (0.0, 0.0, math.nan), "m"],
    "mass": [-1.0, math.nan, math.inf, "1"],
    "axis": [(0.0, 0.0, 0.0), (math.nan, 1.0, 0.0), (1.0, 0.0), "z"],
    "normal": [(0.0, 0.0, 0.0), (0.0, 0.0), (math.inf, 0.0, 1.0)],
    "mass_flow": [math.nan, math.inf, "1", None],
}


@INPUTS
@given(st.sampled_from([(name, v) for name, vs in BAD.items() for v in vs]))
def test_bad_builder_argument_is_named(arg):
    name, value = arg
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0, fluid_mass=0.5)
    _refused(lambda: BUILDER_CALLS[name](b, n0, sec, value), name)


@INPUTS
@given(angle=st.floats(math.pi * 1.001, 2 * math.pi), sign=st.sampled_from([-1.0, 1.0]), n=st.integers(1, 3))
def test_arc_element_of_more_than_half_a_turn_is_refused(angle, sign, n):
    """Found by the fuzz run: an arc of 2 pi in one element made an element whose ends
    coincide to round-off (chord 1e-16 m), and a LinAlgError from the eigen-solver."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0)
    if angle / n > math.pi:
        _refused(lambda: b.add_arc(n0, center=(0.0, 1.0, 0.0), angle=sign * angle, normal=(0, 0, 1), n_elements=n,
                                   section=sec), "n_elements")
    else:
        assert len(b.add_arc(n0, center=(0.0, 1.0, 0.0), angle=sign * angle, normal=(0, 0, 1), n_elements=n,
                             section=sec)) == n + 1


@pytest.fixture(scope="module")
def small():
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 2, pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0,
                                                        rotary_inertia=(1e-3, 1e-3, 1e-3)))
    b.clamp(n0)
    return b.build()


ANALYSIS_CALLS = {
    "load_steps": lambda m, v: pf.static_equilibrium(m, load_steps=v),
    "max_iterations": lambda m, v: pf.static_equilibrium(m, max_iterations=v),
    "tol": lambda m, v: pf.static_equilibrium(m, tol=v),
    "mass_flow": lambda m, v: pf.linearize(m, mass_flow=v),
    "n_modes": lambda m, v: pf.eigenvalues(pf.linearize(m), n_modes=v),
    "steps_per_unit": lambda m, v: pf.critical_mass_flow(m, steps_per_unit=v),
    "mass_flow_max": lambda m, v: pf.critical_mass_flow(m, mass_flow_max=v),
    "t_end": lambda m, v: pf.simulate(m, v, step=1e-3, progress=False),
    "n_outputs": lambda m, v: pf.simulate(m, 0.01, n_outputs=v, step=1e-3, progress=False),
    "step": lambda m, v: pf.simulate(m, 0.01, integrator="generalized_alpha", step=v, progress=False),
    "rho_inf": lambda m, v: pf.simulate(m, 0.01, step=1e-3, rho_inf=v, progress=False),
    "rtol": lambda m, v: pf.simulate(m, 0.01, integrator="ida", rtol=v, progress=False),
}
BAD_OPTIONS = {
    "load_steps": [0, -1, 2.5, "3", None, math.nan],
    "max_iterations": [0, -5, 1.5, "x"],
    "tol": [0.0, -1e-8, math.nan, math.inf, "1e-8"],
    "mass_flow": [math.nan, math.inf, "5"],
    "n_modes": [0, -2, 1.5, "4"],
    "steps_per_unit": [0, -1, 0.5, "4"],
    "mass_flow_max": [0.0, -1.0, math.nan, math.inf],
    "t_end": [0.0, -1.0, math.nan, math.inf, "1"],
    "n_outputs": [0, -1, 2.5, "3"],
    "step": [0.0, -1e-3, math.nan, math.inf],
    "rho_inf": [-0.1, 1.5, math.nan, "0.9"],
    "rtol": [0.0, -1.0, math.nan],
}


@INPUTS
@given(st.sampled_from([(name, v) for name, vs in BAD_OPTIONS.items() for v in vs]))
def test_bad_analysis_option_is_named(small, arg):
    name, value = arg
    _refused(lambda: ANALYSIS_CALLS[name](small, value), name)


@INPUTS
@given(st.sampled_from([("length", 0.0), ("length", -1.0), ("length", math.nan), ("n_elements", 3),
                        ("n_elements", 0), ("n_elements", 2.5), ("internal_modes", -1), ("internal_modes", 1.5),
                        ("curvature", math.nan), ("reduction", "modal")]))
def test_bad_flexible_body_argument_is_named(arg):
    from pipeflex.multibody import flexible_body

    name, value = arg
    kw = dict(length=1.0, n_elements=4, section=pf.PipeSection(EI=1.0, pipe_mass=1.0))
    _refused(lambda: flexible_body(**{**kw, name: value}), name)


# -- 3. invariants at random states -------------------------------------------------------

rotations = st.tuples(*[st.floats(-3.0, 3.0)] * 3).map(lambda w: _core.rotation_exp(np.array(w)))
translations = st.tuples(*[st.floats(-10.0, 10.0)] * 3).map(np.array)


@FAST
@given(sec=models.sections(), curved=st.booleans(), R=rotations, t=translations,
       angle=st.floats(0.1, 2.0), length=models.log_uniform(0.05, 3.0))
def test_rigid_motion_gives_no_elastic_force(sec, curved, R, t, angle, length):
    """A pipe element moved rigidly (through its node frames, at rest, no flow or
    gravity) has zero residual, also curved and with shear."""
    section = pf.PipeSection(**sec)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    if curved:
        b.add_arc(n0, center=(0.0, length, 0.0), angle=angle, normal=(0, 0, 1), n_elements=1, section=section)
    else:
        b.add_line(n0, (length, 0.0, 0.0), 1, section)
    b.clamp(n0)
    model = b.build()
    data, x = model.core.pipe(0), model.positions
    q = np.concatenate([R @ x[0] + t, np.zeros(3), R @ x[1] + t, np.zeros(3)])
    ld = _core.LoadState()
    r, _ = _core.pipe_tangent(data, R, R, ld, q, np.zeros(12), np.zeros(12), 0.0, 0.0, 0.0)
    scale = max(section.EI, section.EIz, section.GJ) / data.l0**2 + section.EA
    assert np.abs(r).max() <= 1e-9 * scale


@FAST
@given(curvature=st.floats(-3.0, 3.0), r=st.lists(translations, min_size=2, max_size=2),
       R=st.lists(rotations, min_size=2, max_size=2), modes=st.integers(0, 2))
def test_rigid_motion_gives_no_elastic_force_ffrf(curvature, r, R, modes):
    """Floating-frame bodies moved rigidly, with eta = eta0 (a preimposed curvature is
    stress-free): no force, whatever the frames."""
    from pipeflex.multibody import MultibodyBuilder, flexible_body

    body = flexible_body(length=1.0, n_elements=4, section=pf.PipeSection(EI=3.0, pipe_mass=1.0, fluid_mass=0.5),
                         internal_modes=modes, curvature=curvature)
    b = MultibodyBuilder()
    j0 = b.add_body(body, position=(0.0, 0.0, 0.0))
    j1 = b.add_body(body, position=(0.0, 2.0, 0.0))
    b.fix(j0, "start")
    b.fix(j1, "start")
    s = b.build()
    state = s.initial_state()
    for j in range(2):
        state.r[j] = r[j]
        state.R[j] = R[j]
    F = s.evaluate(state, mass_flow=0.0, gravity_factor=0.0, load_factor=0.0, tangent=False)[0]
    assert np.abs(F).max() < 1e-10 * 3.0


@FAST
@given(m=models.pipe_models(max_elements=6), d=models.unit)
def test_translation_mass_is_the_total_mass(m, d):
    """u^T M u for a uniform unit translation u of the unsupported model is the total
    mass: the sections' (Model.total_mass) plus the point masses."""
    model, _ = models.build_pipe(m)
    free = model.free_model()
    M = pf.linearize(free, mass_flow=0.0).M.toarray()
    B = free.basis.toarray()
    u = np.zeros(B.shape[0])
    for k in range(3):
        u[k::6] = models._norm(d)[k]
    y = np.linalg.lstsq(B, u, rcond=None)[0]
    assert np.allclose(B @ y, u)
    expected = model.total_mass + sum(pm["mass"] for pm in m["point_masses"])
    assert y @ M @ y == pytest.approx(expected, rel=1e-12)


@settings(FAST, max_examples=8)
@given(m=models.pipe_models(max_elements=4, fluid=False, rotary=True, supports=("clamp", "clamp_both"), loads=0.01),
       kick=st.floats(0.01, 0.5), node=st.integers(0, 20))
def test_energy_is_conserved_without_flow(m, kick, node):
    """Generalised-alpha with rho_inf = 1 (no numerical damping) at a step of 1/200 of
    the fastest period: E(t) - E(0) - W_loads = 0 to 1e-3 E over 40 steps (gravity,
    dead and follower loads, a random initial velocity; loads are applied from t = 0)."""
    model, _ = models.build_pipe(m)
    try:
        w = np.abs(pf.eigenvalues(pf.linearize(model)).values.imag)
    except (ValueError, pf.ConvergenceError):
        assume(False)
    assume(len(w) and w.max() > 0)
    h = 2 * np.pi / w.max() / 200
    st0 = models._kick(model, model.initial_state(), dict(kick=kick, kick_node=node))
    try:
        r = pf.simulate(model, 40 * h, integrator="generalized_alpha", step=h, rho_inf=1.0, state=st0,
                        n_outputs=5, progress=False)
    except pf.ConvergenceError:
        assume(False)
    E = np.abs(r.kinetic) + np.abs(r.elastic) + np.abs(r.gravity_potential) + np.abs(r.load_work)
    assert np.all(r.fluid_work == 0.0)
    assert np.abs(r.energy_balance()).max() <= 1e-3 * max(E.max(), 1e-300)


@settings(FAST, max_examples=6)
@given(n_bodies=st.integers(1, 2), modes=st.integers(0, 1), force=st.tuples(*[st.floats(-1.0, 1.0)] * 3)
       .filter(lambda f: np.linalg.norm(f) > 0.2), joint=st.sampled_from(["rigid", "spherical"]))
def test_multibody_energy_is_conserved_without_flow(n_bodies, modes, force, joint):
    """A chain deflected by a random tip force, then released without it and without
    flow: the multibody integrator (rho_inf = 0.99, little damping) keeps its energy to
    1e-4 (as tests/test_ffrf_scenes.py's cantilever, here with random loads, bodies,
    joints and internal modes)."""
    from pipeflex.multibody import MultibodyBuilder, flexible_body, simulate, static_equilibrium

    body = flexible_body(length=0.5, n_elements=4, internal_modes=modes,
                         section=pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=2.5e4,
                                                rotary_inertia=(6.4e-3, 1e-4, 1e-4)))

    def chain(load):
        b = MultibodyBuilder()
        for j in range(n_bodies):
            b.add_body_between(body, (0.5 * j, 0.0, 0.0), (0.5 * (j + 1), 0.0, 0.0))
        b.fix(0, "start")
        for j in range(n_bodies - 1):
            (b.rigid if joint == "rigid" else b.spherical)(j, "end", j + 1, "start")
        if joint == "spherical":  # the ball joints' twist: held at the tip
            b.roller(n_bodies - 1, "end", (1.0, 0.0, 0.0))
        if load:
            b.add_load(n_bodies - 1, "end", force=tuple(2.0 * x for x in force))
        return b.build()

    try:
        st0 = static_equilibrium(chain(True), mass_flow=0.0).state
    except (ValueError, pf.ConvergenceError):
        assume(False)
    free = chain(False)
    res = simulate(free, 0.2, step=5e-4, state=st0, mass_flow=0.0, rho_inf=0.99, n_outputs=6)
    E = np.array([free.energy(res.state(k)) for k in range(len(res.t))])
    assert np.all(np.isfinite(E)) and E[0] > 0
    assert np.abs(E - E[0]).max() <= 1e-4 * E[0]


# -- 4. fixed bugs stay fixed: their reproducers from the fuzz -------------------------

def _reproducers(kind):
    import json
    from pathlib import Path

    bugs = json.loads((Path(__file__).parent / "fuzz" / "open_bugs.json").read_text())
    return [b["case"] for b in bugs if kind in b["kind"]]


@pytest.mark.parametrize("kind", ["LinAlgError", "need at least one array", "crash",
                                  "calls the model a mechanism"])
def test_fuzz_reproducers_of_fixed_bugs(kind):
    cases = _reproducers(kind)
    assert cases, f"no reproducer of {kind!r} in tests/fuzz/open_bugs.json"
    for case in cases:
        models.run_case(case)  # raises models.Bug if the bug is back
