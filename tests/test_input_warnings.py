"""Inputs a user gets wrong: unit slips (UnitWarning), the step simulate reports, and the
error of a model without the polar rotary inertia time integration needs."""
import warnings

import numpy as np
import pytest

import pipeflex as pf
from pipeflex.errors import UnitWarning

STEEL = dict(outer_diameter=0.0508, inner_diameter=0.0408, E=2.08e11, G=8.0e10, density=7850.0,
             fluid_density=1000.0)


def tube(**changes):
    return pf.PipeSection.tube(**{**STEEL, **changes})


def test_plausible_si_inputs_warn_nothing():
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        tube()
        tube(E=2e6, G=7e5, density=1100.0, fluid_density=1.2)  # a silicone hose carrying air
        tube(fluid_bulk_modulus=2.2e9)
        b = pf.ModelBuilder()
        b.set_gravity((0.0, 0.0, -9.81))


@pytest.mark.parametrize("changes, words", [
    (dict(outer_diameter=50.8, inner_diameter=40.8), ["outer_diameter = 50.8 m", "millimetres", "0.0508 m"]),
    (dict(E=208.0), ["E = 208 Pa", "GPa", "2.08e+11 Pa"]),
    (dict(G=80.0), ["G = 80 Pa", "GPa"]),
    (dict(E=2.08e20), ["E = 2.08e+20 Pa", "diamond"]),
    (dict(density=7.85), ["density = 7.85 kg/m^3", "g/cm^3", "7850 kg/m^3"]),
    (dict(density=7.85e6), ["density = 7.85e+06 kg/m^3", "check the units"]),
    (dict(fluid_density=1e6), ["fluid_density = 1e+06 kg/m^3", "check the units"]),
    (dict(fluid_bulk_modulus=2.2), ["fluid_bulk_modulus = 2.2 Pa", "GPa"]),
])
def test_a_unit_slip_in_a_tube_warns_naming_the_parameter_value_and_slip(changes, words):
    with pytest.warns(UnitWarning) as rec:
        sec = tube(**changes)
    message = str(rec[0].message)
    for w in words:
        assert w in message, message
    assert rec[0].filename == __file__  # points at the user's line, not into pipeflex
    assert isinstance(sec, pf.PipeSection)  # used as given


def test_gravity_in_mm_per_s2_warns_in_the_builder_and_in_multibody_systems():
    b = pf.ModelBuilder()
    with pytest.warns(UnitWarning, match=r"\|gravity\| = 9810 m/s\^2 .*mm/s\^2.*9\.81 m/s\^2"):
        b.set_gravity((0.0, 0.0, -9810.0))
    from pipeflex.multibody import MultibodyBuilder

    with pytest.warns(UnitWarning, match="gravity"):
        MultibodyBuilder().set_gravity((0.0, -9810.0, 0.0))


def test_unit_warning_is_a_user_warning():
    assert issubclass(UnitWarning, UserWarning)


# -- the step simulate reports --------------------------------------------------------------

@pytest.fixture(scope="module")
def cantilever():
    return pf.scenes.cantilever_pipe(n_elements=4, polar_inertia=1e-4)


def test_a_step_longer_than_the_output_spacing_is_reported_as_the_step_taken(cantilever):
    r = pf.simulate(cantilever, 1.0, integrator="generalized_alpha", step=0.05, n_outputs=201, progress=False)
    assert r.stats["steps"] == 200  # the core steps at the output spacing, 5 ms
    assert r.metadata["step"] == pytest.approx(0.005, rel=1e-12)
    assert r.metadata["requested_step"] == 0.05


def test_a_step_that_does_not_divide_the_spacing_is_reported_shortened(cantilever):
    r = pf.simulate(cantilever, 0.1, integrator="generalized_alpha", step=3e-3, n_outputs=21, progress=False)
    assert r.stats["steps"] == 40  # 5 ms intervals in two steps each
    assert r.metadata["step"] == pytest.approx(2.5e-3, rel=1e-12)


def test_a_step_that_divides_the_spacing_is_reported_as_given(cantilever):
    r = pf.simulate(cantilever, 0.1, integrator="generalized_alpha", step=1e-3, n_outputs=21, progress=False)
    assert r.metadata["step"] == 1e-3 and r.stats["steps"] == 100


def test_ida_reports_no_step(cantilever):
    r = pf.simulate(cantilever, 0.01, integrator="ida", n_outputs=3, progress=False)
    assert r.metadata["step"] is None and r.metadata["requested_step"] is None


# -- the missing polar rotary inertia ----------------------------------------------------------

def test_the_readme_cantilever_without_polar_inertia_names_it_in_the_error():
    m = pf.scenes.cantilever_pipe(n_elements=8)
    with pytest.raises(ValueError) as err:
        pf.simulate(m, 0.1, progress=False)
    text = str(err.value)
    for words in ("mass matrix is singular", "polar rotary inertia", "rho I_p", "0 in 8 of the 8 pipe elements",
                  "rotary_inertia=", "polar_inertia=", "pf.scenes.cantilever_pipe(n_elements=8, polar_inertia=",
                  "fix_rotation"):
        assert words in text, text
    r = pf.simulate(pf.scenes.cantilever_pipe(n_elements=8, polar_inertia=1e-4), 0.01, n_outputs=3, progress=False)
    assert np.all(np.isfinite(r.x))
