"""Typed solver errors: the C++ core raises pipeflex.errors classes with the failure's
whereabouts as attributes, so that nobody parses a message."""
import pickle
import re
from pathlib import Path

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core
from pipeflex.errors import ConvergenceError, SingularMatrixError
from pipeflex.multibody import MultibodyBuilder, flexible_body, simulate

from helpers import fluttering_cantilever, u_tube


def test_generalized_alpha_failure_carries_time_iteration_residual():
    m, st = fluttering_cantilever()
    with pytest.raises(ConvergenceError, match="generalised-alpha failed") as err:
        pf.simulate(m, 0.01, integrator="generalized_alpha", state=st, progress=False, step=1e-3, max_newton=1,
                    newton_tol=1e-15, min_step=5e-4)
    e = err.value
    assert type(e) is ConvergenceError
    assert isinstance(e.time, float) and 0.0 <= e.time < 0.01
    assert e.iteration == 1
    assert isinstance(e.residual, float) and e.residual > 0
    assert e.mass_flow == pytest.approx(40.0)
    assert e.load_factor is None


def test_ida_failure_carries_time():
    m, st = fluttering_cantilever()
    with pytest.raises(ConvergenceError, match="IDA failed at t =") as err:
        pf.simulate(m, 0.1, state=st, progress=False, integrator="ida", rtol=1e-30, atol=1e-30)
    assert isinstance(err.value.time, float) and 0.0 <= err.value.time < 0.1
    assert err.value.iteration is None and err.value.residual is None


def test_divergence_carries_time():
    m, st = fluttering_cantilever()
    with pytest.raises(ConvergenceError, match="diverged") as err:
        pf.simulate(m, 20.0, state=st, progress=False, divergence_limit=0.05)
    assert 0.0 < err.value.time < 20.0


def test_multibody_failure_carries_time_iteration_residual():
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=2.5e4, rotary_inertia=(6.4e-3, 0, 0))
    b = MultibodyBuilder()
    j0 = b.add_body(flexible_body(length=0.5, n_elements=4, section=sec), position=(0.25, 0.0, 0.0))
    b.fix(j0, "start")
    b.add_load(j0, "end", force=(0.0, 0.0, 1.5))
    with pytest.raises(ConvergenceError, match="Newton did not converge") as err:
        simulate(b.build(), 0.01, step=1e-3, max_newton=1, newton_tol=1e-15, mass_flow=30.0)
    e = err.value
    # the step is halved down to 1e-12 s before giving up: it fails within the first step
    assert 0.0 <= e.time < 1e-3
    assert e.iteration == 1
    assert e.residual > 0 and e.mass_flow == pytest.approx(30.0)


def test_static_failure_carries_the_load_factor():
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (1, 0, 0), 4, pf.PipeSection(EI=2.0, pipe_mass=1.0, EA=1e9))
    b.clamp(n0)
    b.add_load(nodes[-1], moment=(0.0, 0.0, 50.0), follower=True)
    with pytest.raises(ConvergenceError) as err:
        pf.static_equilibrium(b.build(), max_iterations=1, max_bisections=1)
    e = err.value
    assert type(e) is ConvergenceError
    assert e.load_factor == pytest.approx(0.5)
    assert e.iteration == 1 and e.residual > 0 and e.mass_flow == 0.0 and e.time is None


def test_singular_tangent_is_a_singular_matrix_error():
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (1, 0, 0), 2, pf.PipeSection(EI=1.0, pipe_mass=1.0))
    b.pin(n0)  # a mechanism
    b.add_load(nodes[-1], force=(0.0, 1.0, 0.0))
    with pytest.raises(SingularMatrixError) as err:
        pf.static_equilibrium(b.build(), max_bisections=1)
    assert isinstance(err.value, pf.ConvergenceError)
    assert err.value.load_factor == pytest.approx(0.5)


def test_critical_flow_names_the_flow_of_a_failed_static_solve(monkeypatch):
    """The U-tube's static path ends in a fold that critical_mass_flow reports
    (tests/test_critical_flow.py); a static solve failing where the stiffness does not
    vanish (here forced above 200 kg/s) is still an error naming the flow."""
    from pipeflex.analysis import critical

    real = critical.static_equilibrium

    def failing(model, **kw):
        if kw["mass_flow"] > 200.0:
            e = ConvergenceError(f"static equilibrium failed at mdot = {kw['mass_flow']:.6g} kg/s", load_factor=1.0,
                                 iteration=25, residual=1.0, mass_flow=kw["mass_flow"])
            e.reached_mass_flow, e.reached_state = kw.get("from_mass_flow"), kw["state"]
            raise e
        return real(model, **kw)

    monkeypatch.setattr(critical, "static_equilibrium", failing)
    with pytest.raises(ConvergenceError, match=r"static solve failed at mdot = [0-9.]+ kg/s") as err:
        pf.critical_mass_flow(u_tube())
    e = err.value
    assert "no fold" in str(e)
    assert e.mass_flow > 0 and f"{e.mass_flow:.6g} kg/s" in str(e)
    assert isinstance(e.__cause__, ConvergenceError) and e.load_factor == e.__cause__.load_factor


def test_critical_flow_without_instability_names_the_bracket():
    with pytest.raises(ConvergenceError, match=r"no instability .*\[0, 10\] kg/s") as err:
        pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=2), mass_flow_max=10.0)
    assert err.value.mass_flow == 10.0


def test_attributes_survive_pickling():
    e = SingularMatrixError("x", time=1.5, iteration=3, residual=2.0, load_factor=0.5, mass_flow=4.0)
    back = pickle.loads(pickle.dumps(e))
    assert type(back) is SingularMatrixError and str(back) == "x"
    assert (back.time, back.iteration, back.residual, back.load_factor, back.mass_flow) == (1.5, 3, 2.0, 0.5, 4.0)


def test_add_increment_refuses_an_unknown_target():
    m, st = fluttering_cantilever()
    with pytest.raises(ValueError, match='"q", "v" or "a".*"b"'):
        _core.add_increment(m.core, st, np.zeros(m.n_dofs), "b")


def test_no_exception_message_is_parsed():
    """A caught exception's message is never searched for numbers: use its attributes."""
    package = Path(pf.__file__).parent
    offenders = []
    for path in sorted(package.rglob("*.py")):
        text = path.read_text()
        for m in re.finditer(r"re\.(search|match|fullmatch|findall|finditer)\(([^\n]*)", text):
            if re.search(r"str\(\s*\w+\s*\)|message|\bmsg\b|\.args\b", m.group(2)):
                offenders.append(f"{path.relative_to(package)}: {m.group(0)}")
    assert not offenders, offenders
