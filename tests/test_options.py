"""One vocabulary of options: the flow of scenes (mass_flow [kg/s], or flow_speed [m/s]
where the paper speaks of a speed), renamed options that still work with a
DeprecationWarning, and PipeSection fields that mean one thing in every formulation."""
import inspect
import warnings

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import multibody, scenes
from pipeflex.seeds.seed002 import studies as rs


@pytest.fixture
def no_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        yield


# -- scenes: the flow --------------------------------------------------------------------

FLOW_SCENES = ["cantilever_pipe", "simply_supported_pipe", "sprinkler", "coriolis_meter", "ffrf_cantilever_pipe",
               "ffrf_curved_pipe", "concrete_printer"]
SPEED_SCENES = {  # scenes whose paper gives a speed, with their other required arguments
    "ffrf_cantilever_pipe": dict(n_bodies=2, elements_per_body=2),
    "ffrf_curved_pipe": dict(E=95.85e9, n_bodies=2, elements_per_body=2),
    "concrete_printer": dict(),
}


@pytest.mark.parametrize("name", FLOW_SCENES)
def test_every_flow_scene_takes_mass_flow_keyword_only(name):
    params = inspect.signature(getattr(scenes, name)).parameters
    assert params["mass_flow"].kind is inspect.Parameter.KEYWORD_ONLY
    if "flow_speed" in params:
        assert name in SPEED_SCENES and params["flow_speed"].kind is inspect.Parameter.KEYWORD_ONLY


@pytest.mark.parametrize("name", sorted(SPEED_SCENES))
def test_both_flow_parameters_refused(name):
    with pytest.raises(ValueError, match=r"mass_flow.*flow_speed.*not both"):
        getattr(scenes, name)(mass_flow=1.0, flow_speed=1.0, **SPEED_SCENES[name])


def test_printer_needs_a_flow_and_speed_needs_fluid():
    with pytest.raises(ValueError, match=r"mass_flow \[kg/s\] or flow_speed \[m/s\]"):
        scenes.concrete_printer()
    dry = pf.PipeSection(EI=10.0, pipe_mass=8.0)
    with pytest.raises(ValueError, match="flow_speed needs a section with fluid_mass > 0"):
        scenes.ffrf_cantilever_pipe(n_bodies=1, elements_per_body=2, section=dry, flow_speed=1.0)
    with pytest.raises(ValueError, match="flow_speed must be finite"):
        scenes.ffrf_cantilever_pipe(n_bodies=1, elements_per_body=2, flow_speed=float("inf"))


def _fluid_mass(system):
    return system.bodies[0].section.fluid_mass


def test_flow_speed_and_mass_flow_give_the_same_cantilever(no_warnings):
    by_speed = scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=2, tip_force=1.5, flow_speed=15.0)
    by_flow = scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=2, tip_force=1.5,
                                          mass_flow=_fluid_mass(by_speed) * 15.0)
    assert by_speed.mass_flow == by_flow.mass_flow == 30.0
    assert scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=2).mass_flow == 0.0
    a, b = (multibody.simulate(s, 0.004, step=1e-3, n_outputs=3) for s in (by_speed, by_flow))
    # exact: both options give the same mass flow, so the same run in the same process
    np.testing.assert_array_equal(a.eta, b.eta)
    np.testing.assert_array_equal(a.r, b.r)


def test_flow_speed_and_mass_flow_give_the_same_curved_pipe(no_warnings):
    kw = SPEED_SCENES["ffrf_curved_pipe"]
    default = scenes.ffrf_curved_pipe(**kw)                      # the seed's 10 m/s
    by_speed = scenes.ffrf_curved_pipe(flow_speed=10.0, **kw)
    by_flow = scenes.ffrf_curved_pipe(mass_flow=_fluid_mass(default) * 10.0, **kw)
    assert default.mass_flow == by_speed.mass_flow == by_flow.mass_flow
    a, b = (multibody.simulate(s, 0.003, step=1e-3, n_outputs=2) for s in (by_speed, by_flow))
    np.testing.assert_array_equal(a.v, b.v)


def test_flow_speed_and_mass_flow_give_the_same_printer(no_warnings):
    by_speed = scenes.concrete_printer(flow_speed=6.0)
    pipe = by_speed.bodies[by_speed.info["pipe"]["OE"]]
    by_flow = scenes.concrete_printer(mass_flow=pipe.section.fluid_mass * 6.0)
    assert by_speed.mass_flow == by_flow.mass_flow
    assert by_flow.info["flow_speed"] == pytest.approx(6.0, rel=1e-15)
    st = by_speed.initial_state()
    for x, y in zip(by_speed.evaluate(st, mass_flow=by_speed.mass_flow, tangent=False),
                    by_flow.evaluate(st, mass_flow=by_flow.mass_flow, tangent=False)):
        np.testing.assert_array_equal(x, y)


# -- renamed options ----------------------------------------------------------------------

def test_model_is_renamed_elastic_in_seed002_scenes():
    with pytest.warns(DeprecationWarning, match="'model' is deprecated, use 'elastic'"):
        old = scenes.rotating_cantilever(n_elements=2, model="0")
    assert old.info["elastic"] == "0" and old.elements[0].elastic == "0"
    with pytest.warns(DeprecationWarning, match="use 'elastic'"):
        old = scenes.spin_up_beam(n_elements=1, model="0")
    new = scenes.spin_up_beam(n_elements=1, elastic="0")
    assert old.info["elastic"] == new.info["elastic"] == "0"
    with pytest.raises(TypeError, match="'elastic' and its deprecated name 'model'"):
        scenes.rotating_cantilever(model="0", elastic="A")


def test_model_is_renamed_elastic_in_seed002_studies():
    with pytest.warns(DeprecationWarning, match="unstable\\(\\): the parameter 'model' is deprecated, use 'elastic'"):
        old = rs.unstable(n_elements=1, omega=1.0, model="0")
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        assert rs.unstable(n_elements=1, omega=1.0, elastic="0") == old
    with pytest.warns(DeprecationWarning, match="'rtol' is deprecated, use 'tol'"):
        assert rs.critical_rate(n_elements=1, elastic="A", rtol=1e-2) == float("inf")
    for fn in (rs.spin_up, rs.critical_rate):
        assert "elastic" in inspect.signature(fn).parameters and "model" not in inspect.signature(fn).parameters


def test_critical_mass_flow_rtol_is_tol():
    m = scenes.cantilever_pipe(n_elements=2)
    with pytest.warns(DeprecationWarning, match="'rtol' is deprecated, use 'tol'"):
        old = pf.critical_mass_flow(m, rtol=1e-8).mass_flow
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        assert pf.critical_mass_flow(m, tol=1e-8).mass_flow == old


def test_rotating_state_steps_is_continuation_steps():
    m = scenes.rotating_cantilever(n_elements=2)
    with pytest.warns(DeprecationWarning, match="'steps' is deprecated, use 'continuation_steps'"):
        old = pf.rotating_state(m, 3.0, steps=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        new = pf.rotating_state(m, 3.0, continuation_steps=2)
    np.testing.assert_array_equal(old.q, new.q)
    with pytest.raises(ValueError, match="tol must be > 0"):
        pf.rotating_state(m, 3.0, tol=0.0)


def test_multibody_simulate_uses_the_integrator_vocabulary():
    s = scenes.ffrf_cantilever_pipe(n_bodies=1, elements_per_body=2, tip_force=1.0)
    params = inspect.signature(multibody.simulate).parameters
    for name in ("step", "rho_inf", "newton_tol", "max_newton"):
        assert name in params
    assert params["rho_inf"].default == 0.8            # index 3: needs rho_inf < 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        new = multibody.simulate(s, 0.003, step=1e-3, n_outputs=2, newton_tol=1e-9, max_newton=10)
    with pytest.warns(DeprecationWarning) as rec:
        old = multibody.simulate(s, 0.003, step=1e-3, n_outputs=2, tol=1e-9, max_iterations=10)
    messages = " ".join(str(w.message) for w in rec)
    assert "use 'newton_tol'" in messages and "use 'max_newton'" in messages
    np.testing.assert_array_equal(old.eta, new.eta)
    with pytest.raises(ValueError, match="newton_tol must be > 0"):
        multibody.simulate(s, 0.003, step=1e-3, newton_tol=0.0)
    with pytest.raises(TypeError, match="'newton_tol' and its deprecated name 'tol'"):
        multibody.simulate(s, 0.003, step=1e-3, tol=1e-9, newton_tol=1e-9)


def test_element_simulate_takes_the_same_names():
    m = scenes.cantilever_pipe(n_elements=2, polar_inertia=1e-3)
    r = pf.simulate(m, 0.002, integrator="generalized_alpha", step=1e-3, rho_inf=0.8, newton_tol=1e-9,
                    max_newton=10, n_outputs=2, progress=False)
    assert r.metadata["options"]["newton_tol"] == 1e-9


# -- section fields -----------------------------------------------------------------------

@pytest.mark.parametrize("field, value", [("kv", 4.0 / 3.0), ("GAy", 1e5), ("GAz", 1e5)])
def test_ffrf_body_refuses_what_it_ignores(field, value):
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, **{field: value})
    with pytest.raises(ValueError, match=rf"section\.{field} = .*does not support .* yet"):
        multibody.flexible_body(length=1.0, n_elements=2, section=sec)


def test_ffrf_cantilever_refuses_kv():
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, kv=4.0 / 3.0)
    with pytest.raises(ValueError, match="kv"):
        scenes.ffrf_cantilever_pipe(n_bodies=1, elements_per_body=2, section=sec)


@pytest.mark.parametrize("field, value", [("kv", 4.0 / 3.0), ("GAy", 1e5), ("GAz", 1e5),
                                          ("rotary_inertia", (0.0, 0.0, 1e-3)), ("GJ", 3.0)])
def test_ancf_beam_refuses_what_it_ignores(field, value):
    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0, **{field: value})
    with pytest.raises(ValueError, match=rf"section\.{field} = "):
        pf.ModelBuilder().add_ancf_beam((0, 0, 0), (1, 0, 0), 2, sec)


def _ancf_first_frequency(**section):
    b = pf.ModelBuilder()
    nodes = b.add_ancf_beam((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 4, pf.PipeSection(pipe_mass=1.0, EA=1e4, **section))
    b.clamp(nodes[0])
    lam = pf.eigenvalues(pf.linearize(b.build())).values
    return float(np.abs(lam.imag).min(initial=np.inf, where=np.abs(lam.imag) > 0))


def test_ancf_beam_bends_with_eiz():
    w = _ancf_first_frequency(EI=1.0)
    assert w == pytest.approx(3.516, rel=2e-3)           # 3.516 sqrt(EI / (m L^4))
    assert _ancf_first_frequency(EI=1.0, EIz=4.0) == pytest.approx(2.0 * w, rel=1e-9)
    assert _ancf_first_frequency(EI=7.0, EIz=1.0) == pytest.approx(w, rel=1e-12)   # EI (E I_y) out of plane


def test_pipe_element_keeps_ei_about_y():
    """The 3D element: EI about local y, EIz about local z (no change)."""
    def freqs(**section):
        b = pf.ModelBuilder()
        n0 = b.add_node((0.0, 0.0, 0.0))
        b.add_line(n0, (1.0, 0.0, 0.0), 4, pf.PipeSection(pipe_mass=1.0, EA=1e4, GJ=1.0, **section))
        b.clamp(n0)
        lam = pf.eigenvalues(pf.linearize(b.build())).values
        return np.sort(np.abs(lam.imag[lam.imag > 0]))

    both = freqs(EI=1.0, EIz=4.0)
    assert both[0] == pytest.approx(freqs(EI=1.0)[0], rel=1e-9)      # the soft plane: EI
    assert np.any(np.isclose(both, 2.0 * both[0], rtol=1e-6))          # the stiff plane: EIz


def test_element_curved_model_takes_the_same_flow_names(no_warnings):
    from pipeflex.seeds.seed004.studies import element_curved_model

    default = element_curved_model(95.85e9, n_elements=2)
    mu_f = default.elements[0].section.fluid_mass
    assert element_curved_model(95.85e9, n_elements=2, flow_speed=10.0).mass_flow == default.mass_flow
    assert element_curved_model(95.85e9, n_elements=2, mass_flow=mu_f * 10.0).mass_flow == default.mass_flow
    with pytest.raises(ValueError, match="not both"):
        element_curved_model(95.85e9, mass_flow=1.0, flow_speed=1.0)
