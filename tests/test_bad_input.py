"""Bad input raises ValueError naming the parameter and the rule; never a crash."""
import math

import numpy as np
import pytest

import pipeflex as pf

SEC = dict(EI=1.0, pipe_mass=1.0, fluid_mass=0.5)


@pytest.mark.parametrize("field,value,match", [
    ("EI", -1.0, "EI must be > 0"), ("EI", 0.0, "EI must be > 0"), ("EI", math.nan, "EI must be finite"),
    ("pipe_mass", -0.1, "pipe_mass must be >= 0"), ("fluid_mass", math.inf, "fluid_mass must be finite"),
    ("EA", -5.0, "EA must be > 0"), ("kv", 0.0, "kv must be > 0"), ("GJ", "abc", "GJ must be a real number"),
])
def test_bad_section(field, value, match):
    with pytest.raises(ValueError, match=match):
        pf.PipeSection(**{**SEC, field: value})


def test_massless_section():
    with pytest.raises(ValueError, match="pipe_mass \\+ fluid_mass must be > 0"):
        pf.PipeSection(EI=1.0, pipe_mass=0.0)


@pytest.mark.parametrize("scene", [pf.scenes.cantilever_pipe, pf.scenes.simply_supported_pipe])
@pytest.mark.parametrize("kwargs,match", [
    (dict(n_elements=0), "n_elements must be a positive integer"),
    (dict(n_elements=2.5), "n_elements must be a positive integer"),
    (dict(n_elements=2, length=0.0), "length must be > 0"),
    (dict(n_elements=2, length=-1.0), "length must be > 0"),
    (dict(n_elements=2, EI=-1.0), "EI must be > 0"),
    (dict(n_elements=2, pipe_mass=math.nan), "pipe_mass must be finite"),
    (dict(n_elements=2, fluid_mass=-2.0), "fluid_mass must be >= 0"),
])
def test_bad_scene_parameters(scene, kwargs, match):
    with pytest.raises(ValueError, match=match):
        scene(**kwargs)


def test_zero_length_element():
    b = pf.ModelBuilder()
    a, c = b.add_node((0, 0, 0)), b.add_node((0, 0, 0))
    with pytest.raises(ValueError, match="zero length"):
        b.add_pipe(a, c, pf.PipeSection(**SEC))


def test_element_on_missing_node():
    b = pf.ModelBuilder()
    a = b.add_node((0, 0, 0))
    with pytest.raises(ValueError, match="q refers to node 7"):
        b.add_pipe(a, 7, pf.PipeSection(**SEC))


def test_nan_position():
    with pytest.raises(ValueError, match="position must be finite"):
        pf.ModelBuilder().add_node((0, math.nan, 0))


def test_model_without_supports():
    b = pf.ModelBuilder()
    a = b.add_node((0, 0, 0))
    b.add_line(a, (1, 0, 0), 2, pf.PipeSection(**SEC))
    with pytest.raises(ValueError, match="no supports"):
        b.build()


def test_unknown_component_and_zero_axis():
    b = pf.ModelBuilder()
    a = b.add_node((0, 0, 0))
    with pytest.raises(ValueError, match="unknown component 'uw'"):
        b.fix(a, ["uw"])
    with pytest.raises(ValueError, match="axis must be a non-zero vector"):
        b.hinge(a, (0, 0, 0))


def test_flow_without_fluid():
    b = pf.ModelBuilder()
    a = b.add_node((0, 0, 0))
    b.add_line(a, (1, 0, 0), 2, pf.PipeSection(EI=1.0, pipe_mass=1.0))
    b.clamp(a)
    with pytest.raises(ValueError, match="fluid_mass is 0"):
        b.build(mass_flow=1.0)


def test_bad_analysis_options():
    m = pf.scenes.cantilever_pipe(n_elements=2)
    with pytest.raises(ValueError, match="tol must be > 0"):
        pf.critical_mass_flow(m, tol=0.0)
    with pytest.raises(ValueError, match="mass_flow must be finite"):
        pf.linearize(m, mass_flow=math.nan)
    with pytest.raises(ValueError, match="load_steps must be a positive integer"):
        pf.static_equilibrium(m, load_steps=0)


def test_model_is_immutable():
    m = pf.scenes.cantilever_pipe(n_elements=2)
    with pytest.raises(ValueError):
        m.positions[0, 0] = 1.0
    assert np.all(m.positions[0] == 0.0)
