"""Results as xarray Datasets (units, long names, named dimensions and coordinates), the
sweeps' Datasets labelled the same way, and the summary reprs of Model and Result."""
import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis.periodic import OrbitBranch, PeriodicOrbit
from pipeflex.results import FIELDS, Result

xr = pytest.importorskip("xarray")


def cantilever(EI=10.0, n_elements=3, mass_ratio=0.2):
    return pf.scenes.cantilever_pipe(n_elements=n_elements, EI=EI, pipe_mass=10.0 * (1 - mass_ratio),
                                     fluid_mass=10.0 * mass_ratio, polar_inertia=1e-3)


def short_transient(EI=10.0):
    """A 20 ms start of the flow through a 3-element cantilever, 5 outputs."""
    return pf.simulate(cantilever(EI), 0.02, n_outputs=5, mass_flow=5.0, progress=False,
                       integrator="generalized_alpha", step=1e-3)


def labelled(var):
    """Every variable and coordinate pipeflex makes has a long name."""
    return isinstance(var.attrs.get("long_name"), str) and var.attrs["long_name"]


@pytest.fixture(scope="module")
def transient():
    return short_transient()


# ---------------------------------------------------------------------------------------
# to_xarray

def test_transient_to_xarray_has_named_dims_coordinates_and_units(transient):
    r = transient
    ds = r.to_xarray()
    assert ds.x.dims == ("time", "node", "component") and ds.R.dims == ("time", "node", "row", "column")
    np.testing.assert_array_equal(ds.time.values, r.t)
    np.testing.assert_array_equal(ds.node.values, np.arange(4))
    assert list(ds.component.values) == ["x", "y", "z"]
    np.testing.assert_array_equal(ds.x.values, r.x)
    np.testing.assert_array_equal(ds.omega.sel(node=3, component="z").values, r.omega[:, 3, 2])
    np.testing.assert_array_equal(ds.fluid_work.values, r.fluid_work)
    units = {n: ds[n].attrs.get("units") for n in ("time", "x", "xd", "omega", "R", "kinetic", "fluid_work")}
    assert units == {"time": "s", "x": "m", "xd": "m/s", "omega": "rad/s", "R": "1", "kinetic": "J",
                     "fluid_work": "J"}
    assert all(labelled(ds[n]) for n in ds.variables)
    assert ds.attrs["integrator"] == "generalized_alpha" and ds.attrs["step"] == pytest.approx(1e-3)


def test_transient_dataset_saves_to_netcdf(transient, tmp_path):
    ds = transient.to_xarray()
    ds.to_netcdf(tmp_path / "motion.nc")
    back = xr.load_dataset(tmp_path / "motion.nc")
    xr.testing.assert_identical(back, ds)


def test_to_xarray_does_not_load_xarray_with_pipeflex():
    code = ("import sys, pipeflex as pf; from pipeflex.analysis.transient import TransientResult; "
            "print('xarray' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False"]


def orbit(n_nodes=3, n_t=9, n_dofs=6):
    t = np.linspace(0.0, 0.5, n_t)
    x = np.zeros((n_t, n_nodes, 3))
    x[:, :, 1] = 0.01 * np.sin(2 * np.pi * t / 0.5)[:, None] * np.arange(n_nodes)
    mult = np.array([1.0 + 0j, 0.3 + 0.4j, 0.3 - 0.4j])
    return PeriodicOrbit(mass_flow=25.5, period=0.5, base=None, z0=np.arange(n_dofs, dtype=float),
                         v0=np.zeros(n_dofs), start=None, t=t, x=x, amplitude=np.ptp(x, axis=0) / 2,
                         multipliers=mult, trivial=0, stable=True, residual=1e-12, iterations=4, steps=n_t - 1)


def test_periodic_orbit_to_xarray():
    o = orbit()
    ds = o.to_xarray()
    assert ds.x.dims == ("time", "node", "component") and ds.amplitude.dims == ("node", "component")
    np.testing.assert_array_equal(ds.time.values, o.t)
    np.testing.assert_array_equal(ds.amplitude.sel(component="y").values, o.amplitude[:, 1])
    np.testing.assert_array_equal(ds.multipliers_real.values + 1j * ds.multipliers_imag.values, o.multipliers)
    assert ds.multipliers_imag.dims == ("multiplier",) and ds.z0.dims == ("dof",)
    assert (ds.mass_flow.item(), ds.period.item(), bool(ds.stable)) == (25.5, 0.5, True)
    assert ds.mass_flow.attrs["units"] == "kg/s" and ds.period.attrs["units"] == "s"
    assert "units" not in ds.z0.attrs  # metres and radians mixed: no unit rather than a wrong one
    assert all(labelled(ds[n]) for n in ds.variables)
    without = dataclasses.replace(o, multipliers=np.zeros(0, complex), trivial=-1, stable=None).to_xarray()
    assert "stable" not in without and without.multipliers_real.size == 0


def test_orbit_branch_to_xarray():
    k = 4
    amp = np.random.default_rng(1).random((k, 3, 3))
    br = OrbitBranch(mass_flow=np.array([25.0, 25.5, 26.0, 25.8]), period=np.full(k, 0.5), amplitude=amp,
                     stable=np.array([True, True, False, False]), max_multiplier=np.array([0.5, 0.9, 1.1, 1.2]),
                     folds=np.array([26.0]), hopf=(25.0, 12.6))
    ds = br.to_xarray()
    assert ds.mass_flow.dims == ("orbit",) and ds.amplitude.dims == ("orbit", "node", "component")
    assert ds.folds.dims == ("fold",) and ds.folds.attrs["units"] == "kg/s"
    np.testing.assert_array_equal(ds.amplitude.values, amp)
    assert (ds.hopf_mass_flow.item(), ds.hopf_frequency.item()) == (25.0, 12.6)
    assert ds.hopf_frequency.attrs["units"] == "rad/s"
    assert all(labelled(ds[n]) for n in ds.variables)


def test_campbell_to_xarray():
    beam = pf.scenes.rotating_cantilever(n_elements=3)
    c = pf.campbell(beam, gamma=[0.0, 1.0, 2.0], n_modes=2)
    ds = c.to_xarray()
    assert ds.frequencies.dims == ("speed", "branch")
    np.testing.assert_array_equal(ds.speed.values, c.speeds)
    np.testing.assert_array_equal(ds.gamma.values, c.gamma)
    np.testing.assert_array_equal(ds.frequencies.values, c.frequencies)
    assert list(ds.family.values) == list(c.family)
    assert ds.modes_real.dims == ("speed", "branch", "dof") and ds.mac.dims == ("speed_interval", "branch")
    np.testing.assert_array_equal(ds.modes_real.values + 1j * ds.modes_imag.values, c.modes)
    assert ds.frequencies.attrs["units"] == "rad/s" and ds.speed.attrs["units"] == "rad/s"
    assert ds.attrs["linearization"] == c.linearization
    assert all(labelled(ds[n]) for n in ds.variables)


def test_stability_map_has_units_and_long_names():
    ds = pf.stability_map([0.2, 0.5], n_elements=4, executor="serial", progress=False)
    assert ds.u_cr.attrs["units"] == "1" and ds.mass_flow.attrs["units"] == "kg/s"
    assert ds.mass_ratio.attrs["units"] == "1"
    assert all(labelled(ds[n]) for n in ds.variables)


# ---------------------------------------------------------------------------------------
# sweeps

def critical_flow(EI, mass_ratio):
    return pf.critical_mass_flow(cantilever(EI, mass_ratio=mass_ratio))


def test_a_swept_result_has_units_long_names_and_named_dims():
    ds = pf.sweep(critical_flow, EI=[5.0, 10.0], mass_ratio=[0.2], executor="serial")
    assert ds.mass_flow.attrs == {"units": "kg/s", "long_name": "critical mass flow"}
    assert ds.frequency.attrs["units"] == "rad/s"
    assert ds.mode_real.dims == ("EI", "mass_ratio", "dof") and ds.mode_imag.attrs["units"] == "1"
    assert ds.eigenvalue_real.attrs["units"] == "1/s"
    assert ds.EI.attrs["units"] == "N m^2" and ds.mass_ratio.attrs["units"] == "1"
    assert "units" not in ds.evaluations.attrs and "units" not in ds.error.attrs
    assert ds.attrs["result"] == "CriticalFlow" and "__result__" not in ds
    assert all(labelled(ds[n]) for n in ds.variables)


def test_a_parameter_named_as_an_axis_leaves_the_field_its_numbered_axes():
    ds = pf.sweep(lambda dof: critical_flow(10.0 + dof, 0.2), dof=[0.0, 1.0], executor="serial")
    assert ds.mode_real.dims == ("dof", "mode_dim_0") and ds.mode_real.attrs["units"] == "1"


def test_a_swept_transient_has_time_node_component_dims():
    ds = pf.sweep(short_transient, EI=[10.0, 20.0], executor="serial")
    assert ds.x.dims == ("EI", "time", "node", "component") and ds.t.dims == ("EI", "time")
    assert ds.R.dims == ("EI", "time", "node", "row", "column")
    assert list(ds.component.values) == ["x", "y", "z"]
    assert ds.x.attrs["units"] == "m" and ds.t.attrs["units"] == "s"
    assert not [d for d in ds.dims if "_dim_" in d]
    # the sweep runs BLAS on one thread: a plain call may round differently in the last bits
    np.testing.assert_allclose(ds.x.sel(EI=10.0).values, short_transient(10.0).x, rtol=0, atol=64 * np.spacing(2.0))


def quadratic(a, tag):
    return {"y": a * a, "grad": np.array([2 * a, 1.0])}


def test_a_dict_field_gets_its_name_and_no_unit_and_unknown_parameters_no_unit():
    ds = pf.sweep(quadratic, a=[1.0, 2.0], tag=["p"], executor="serial")
    assert ds.y.attrs == {"long_name": "y"} and ds.grad.dims == ("a", "tag", "grad_dim_0")
    assert ds.a.attrs == {"long_name": "a"}
    assert "result" not in ds.attrs


def test_the_reserved_result_class_field_is_refused():
    ds = pf.sweep(lambda a: {"__result__": a}, a=[1.0], executor="serial")
    assert "__result__" in ds.error.item()


def test_a_store_keeps_the_units(tmp_path):
    first = pf.sweep(critical_flow, EI=[5.0], mass_ratio=[0.2], executor="serial", store=tmp_path / "s")
    again = pf.sweep(critical_flow, EI=[5.0], mass_ratio=[0.2], executor="serial", store=tmp_path / "s")
    xr.testing.assert_identical(first, again)
    assert again.mode_real.dims[-1] == "dof"


def test_the_table_names_only_fields_its_classes_have():
    import pipeflex.analysis.campbell, pipeflex.analysis.critical, pipeflex.analysis.eigen  # noqa: E401
    import pipeflex.analysis.rotating, pipeflex.analysis.static, pipeflex.analysis.steady  # noqa: E401
    import pipeflex.coupled  # noqa: F401 -- registers CoupledStatic (and, through it, MultibodyStatic)
    from pipeflex.results import _REGISTRY

    classes = {cls.__name__: cls for cls in _REGISTRY.values()}
    derived = {"OrbitBranch": {"hopf_mass_flow", "hopf_frequency"},
               "FrequencyResponse": {"backbone_frequency", "backbone_amplitude"}}  # from .backbone
    for kind, fields in FIELDS.items():
        if kind == "stability_map":
            continue
        names = {f.name for f in dataclasses.fields(classes[kind])} | derived.get(kind, set())
        assert set(fields) <= names, (kind, set(fields) - names)
        assert all(len(entry) == 3 and isinstance(entry[2], tuple) for entry in fields.values())


# ---------------------------------------------------------------------------------------
# repr

def test_model_repr_summarises():
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (2.0, 0.0, 0.0), 4, pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0))
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, -1.0, 0.0))
    b.set_gravity((0.0, 0.0, -9.81))
    model = b.build(mass_flow=3.0)
    text = repr(model)
    assert text.startswith("Model(") and len(text) < 400
    for part in ("nodes=5", "elements=4 pipe", "dofs=24", "fixed_coordinates=6", "constrained_nodes=[0]",
                 "mass_flow=3 kg/s", "total_mass=20 kg", "total_length=2 m", "gravity=(0, 0, -9.81) m/s^2",
                 "nodal_loads=1"):
        assert part in text, (part, text)
    html = model._repr_html_()
    assert "<table>" in html and "total_mass" in html and "20 kg" in html


def test_result_repr_shows_scalars_and_array_shapes(transient):
    crit = pf.critical_mass_flow(cantilever())
    text = repr(crit)
    assert text.startswith("CriticalFlow(mass_flow=") and f"mass_flow={crit.mass_flow!r}" in text
    assert "kind='flutter'" in text and f"mode=array(({crit.mode.size},), complex128)" in text
    text = repr(transient)
    assert "x=array((5, 4, 3), float64)" in text and "final_state=State(...)" in text
    assert len(text) < 1000  # no array dumped
    html = transient._repr_html_()
    assert "<table>" in html and "array((5, 4, 3), float64)" in html
    eigen = repr(pf.EigenResult(values=np.array([1j])))
    assert eigen.startswith("EigenResult(values=array((1,), complex128)") and "blocks" not in eigen  # repr=False


def test_a_result_class_with_its_own_repr_keeps_it():
    @dataclasses.dataclass(frozen=True)
    class Mine(Result):
        a: float

        def __repr__(self):
            return "mine"

    assert repr(Mine(1.0)) == "mine"


# ---------------------------------------------------------------------------------------
# Result.load

def _rewrite(path, edit):
    """The .npz at ``path`` with its JSON entry changed by ``edit``."""
    with np.load(path, allow_pickle=False) as f:
        arrays = {k: f[k] for k in f.files}
    meta = json.loads(str(arrays["__result__"][()]))
    edit(meta["root"]["fields"])
    arrays["__result__"] = np.array(json.dumps(meta))
    np.savez(path, **arrays)


def test_load_refuses_an_entry_that_is_not_a_field(tmp_path):
    crit = pf.critical_mass_flow(cantilever())
    path = crit.save(tmp_path / "crit")
    _rewrite(path, lambda fields: fields.update(__class__="oops", _secret=1))
    with pytest.raises(ValueError, match="'__class__', which is not a field of CriticalFlow") as err:
        pf.CriticalFlow.load(path)
    assert str(path) in str(err.value)


def test_load_names_a_missing_field(tmp_path):
    path = pf.critical_mass_flow(cantilever()).save(tmp_path / "crit")
    _rewrite(path, lambda fields: fields.pop("kind"))
    with pytest.raises(ValueError, match="lacks the field 'kind'"):
        pf.CriticalFlow.load(path)


def test_load_still_round_trips(tmp_path, transient):
    back = pf.TransientResult.load(transient.save(tmp_path / "run"))
    np.testing.assert_array_equal(back.x, transient.x)
    assert back.metadata == transient.metadata
