"""pipeflex.sweep: grids, executors (serial, process pool, threads, Dask), failures, the
store (resume after Ctrl-C or a dead worker), netCDF, bad input.

The swept functions live in tests/sweep_functions.py: worker processes import them by name.
"""
import functools
import math
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import pipeflex as pf
import sweep_functions as sf
from pipeflex.sweeps import SweepIncomplete

xr = pytest.importorskip("xarray")
# critical flows computed in two places: 10 x critical_mass_flow's tol (1 ulp in EI moves
# the flow, frequency and mode by ~1e-13 relative, measured; the root search stops within tol)
RTOL_CRITICAL = 1e-9


def sweep(fn, **kwargs):
    kwargs.setdefault("progress", False)
    return pf.sweep(fn, **kwargs)


def assert_same_to_round_off(a, b, *, rtol):
    """Two sweeps of the same points run in different places (processes, a loop): the same
    variables, coordinates, strings, ints and attrs exactly; float variables to ``rtol``
    [-] of each variable's largest value. Not bit for bit: another process aligns its
    arrays differently, and BLAS and numpy's vectorised loops then sum in another order."""
    numeric = [k for k, v in a.data_vars.items() if v.dtype.kind in "fc"]
    xr.testing.assert_identical(a.drop_vars(numeric), b.drop_vars(numeric))
    for k in numeric:
        assert a[k].dims == b[k].dims and b[k].dtype.kind in "fc", k
        x, y = a[k].values, b[k].values
        scale = np.abs(x[np.isfinite(x)]).max(initial=0.0)
        np.testing.assert_allclose(x, y, rtol=rtol, atol=rtol * scale, err_msg=k)


# ---------------------------------------------------------------------------------------
# grids

def test_product_grid_has_the_parameters_as_dimensions_in_order():
    ds = sweep(sf.quadratic, a=[-1.0, 2.0, 3.0], b=[0.0, 1.0], workers=2)
    assert list(ds.y.dims) == ["a", "b"]
    np.testing.assert_array_equal(ds.a, [-1.0, 2.0, 3.0])
    np.testing.assert_array_equal(ds.b, [0.0, 1.0])
    np.testing.assert_array_equal(ds.y, [[1.0, 2.0], [4.0, 5.0], [9.0, 10.0]])
    assert ds.grad.dims == ("a", "b", "grad_dim_0")
    np.testing.assert_array_equal(ds.grad.sel(a=3.0, b=1.0), [6.0, 1.0])
    assert ds.n.dtype == np.int64 and ds.n.sel(a=2.0, b=0.0) == 2  # no failure: ints stay ints
    assert list(ds.label.sel(b=0.0).values) == ["neg", "pos", "pos"] and type(ds.label.values[0, 0]) is str
    assert list(ds.error.values.ravel()) == [""] * 6
    assert ds.attrs["n_failed"] == 0 and ds.attrs["n_points"] == 6 and ds.attrs["grid"] == "product"


def test_zip_grid_has_one_point_dimension_with_the_parameters_as_coordinates():
    ds = sweep(sf.quadratic, grid="zip", a=[1.0, 2.0, 3.0], b=[10.0, 20.0, 30.0], workers=2)
    assert ds.y.dims == ("point",) and ds.a.dims == ("point",) and ds.b.dims == ("point",)
    np.testing.assert_array_equal(ds.y, [11.0, 24.0, 39.0])
    np.testing.assert_array_equal(ds.b, [10.0, 20.0, 30.0])


def test_a_scalar_is_the_variable_value_and_threads_take_local_functions():
    offset = 0.5

    def local(x, y):  # not picklable: fine for threads and in-process
        return math.hypot(x, y) + offset

    with ThreadPoolExecutor(2) as pool:
        threaded = sweep(local, x=[3.0, 5.0], y=[4.0, 12.0], executor=pool)
    serial = sweep(local, x=[3.0, 5.0], y=[4.0, 12.0], executor="serial")
    xr.testing.assert_identical(threaded, serial)  # exact: scalar Python arithmetic, the same on any thread
    np.testing.assert_allclose(serial.value, [[5.5, math.hypot(3, 12) + 0.5], [math.hypot(5, 4) + 0.5, 13.5]])


def test_the_default_pool_runs_one_blas_thread_per_worker():
    ds = sweep(sf.blas_threads, a=[0.0, 1.0, 2.0, 3.0], workers=2)
    assert set(ds.value.values.ravel()) == {1}


# ---------------------------------------------------------------------------------------
# a physics point

def test_critical_flow_sweep_matches_the_serial_loop():
    EI = [5.0, 10.0, 20.0]
    ds = sweep(sf.critical_flow, EI=EI, workers=2)
    from threadpoolctl import threadpool_limits
    with threadpool_limits(limits=1):
        loop = [sf.critical_flow(e) for e in EI]
    # worker processes against this one and the loop: round-off apart (array alignment,
    # BLAS kernels), which the root search (tol = 1e-10) may move by up to its tolerance
    assert_same_to_round_off(sweep(sf.critical_flow, EI=EI, executor="serial"), ds, rtol=RTOL_CRITICAL)
    for name, values in (("mass_flow", [r.mass_flow for r in loop]), ("frequency", [r.frequency for r in loop]),
                         ("eigenvalue_imag", [r.eigenvalue.imag for r in loop]),
                         ("mode_real", [r.mode.real for r in loop])):
        np.testing.assert_allclose(ds[name], values, rtol=RTOL_CRITICAL,
                                   atol=RTOL_CRITICAL * np.abs(values).max(), err_msg=name)
    assert list(ds.kind.values) == ["flutter"] * 3
    assert ds.mode_real.dims == ("EI", "dof")  # the axes of a result field are named (pipeflex.results.FIELDS)
    # mdot_cr = u_cr sqrt(M_f EI) / L, M_f = 2 kg/m: the cantilever's u_cr(beta = 0.2) ~ 5.59
    # (Gregory & Paidoussis), the same for every EI
    u_cr = ds.mass_flow / np.sqrt(2.0 * ds.EI)
    np.testing.assert_allclose(u_cr, 5.59, rtol=0.01)
    np.testing.assert_allclose(u_cr, u_cr[0], rtol=1e-8)


# ---------------------------------------------------------------------------------------
# failures

def test_a_failing_point_is_recorded_and_the_sweep_goes_on():
    ds = sweep(sf.fails_on_negative, a=[-2.0, -1.0, 0.5, 3.0], workers=2)
    assert ds.attrs["n_failed"] == 2
    assert list(ds.error.values) == ["ValueError: a = -2.0 < 0", "ValueError: a = -1.0 < 0", "", ""]
    assert np.isnan(ds.value.values[:2]).all()
    np.testing.assert_array_equal(ds.value.values[2:], [0.25, 9.0])


def test_what_fn_returns_in_the_wrong_form_fails_its_point():
    def wrong(a):
        return [a] if a > 0 else {"v": {"nested": a}}

    ds = sweep(wrong, a=[1.0, -1.0], executor="serial")
    assert ds.attrs["n_failed"] == 2
    assert ds.error.values[0].startswith("TypeError: fn returned a list")
    assert ds.error.values[1].startswith("TypeError: fn returned the field 'v' as a dict")


def test_a_repeated_zip_point_is_computed_once(tmp_path):
    ds = sweep(functools.partial(sf.logged, log=str(tmp_path)), grid="zip", a=[1.0, 1.0, 2.0], executor="serial")
    assert sf.calls(tmp_path) == [1.0, 2.0]
    np.testing.assert_array_equal(ds.value, [2.0, 2.0, 3.0])


def test_ints_become_floats_with_nan_where_a_point_failed(tmp_path):
    fn = functools.partial(sf.logged, log=str(tmp_path), fail_at=2.0)
    ds = sweep(fn, a=[1.0, 2.0], executor="serial")
    assert ds.attrs["n_failed"] == 1 and ds.error.values[1] == "ValueError: no value at a = 2.0"
    np.testing.assert_array_equal(ds.value, [2.0, np.nan])


# ---------------------------------------------------------------------------------------
# store and resume

A = [float(a) for a in range(8)]


def stored(store, values):
    """The values of ``a`` whose points are in the store."""
    from pipeflex.sweeps.grid import point_key

    return {a for a in values if (store / f"{point_key({'a': a})}.npz").exists()}


def test_resume_after_keyboard_interrupt_recomputes_nothing(tmp_path):
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    sf.plan(log, interrupt_at=5.0)
    with pytest.raises(KeyboardInterrupt):
        sweep(functools.partial(sf.logged, log=str(log)), a=A, store=store, workers=2)
    sf.plan(log)
    before = sf.calls(log)
    kept = stored(store, A)
    # finished points are stored; points in flight when the sweep stopped may be lost
    assert 5.0 not in before and 1 <= len(kept) and kept <= set(before)
    resumed = sweep(functools.partial(sf.logged, log=str(log)), a=A, store=store, workers=2)
    new = list(sf.calls(log))
    for a in before:
        new.remove(a)
    assert not kept & set(new) and kept | set(new) == set(A) and len(new) == len(set(new))
    whole_log = tmp_path / "whole"
    whole_log.mkdir()
    whole = sweep(functools.partial(sf.logged, log=str(whole_log)), a=A, executor="serial")
    xr.testing.assert_identical(resumed, whole)  # exact: stored points read back, a + 1 of small integers


def test_resume_in_process_continues_where_it_stopped(tmp_path):
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    sf.plan(log, interrupt_at=3.0)
    with pytest.raises(KeyboardInterrupt):
        sweep(functools.partial(sf.logged, log=str(log)), a=A, store=store, executor="serial")
    sf.plan(log)
    assert sf.calls(log) == [0.0, 1.0, 2.0]
    ds = sweep(functools.partial(sf.logged, log=str(log)), a=A, store=store, executor="serial")
    assert sf.calls(log) == A
    np.testing.assert_array_equal(ds.value, np.array(A) + 1)


def test_a_dead_worker_of_the_default_pool_costs_no_point(tmp_path):
    """The points queued on the broken pool run again, each alone (tests/test_sweep_faults.py:
    a point that dies again fails with its cause)."""
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    sf.plan(log, exit_once_at=4.0)
    ds = sweep(functools.partial(sf.logged, log=str(log)), a=A, store=store, workers=2)
    np.testing.assert_array_equal(ds.value, np.array(A) + 1)
    assert ds.attrs["n_failed"] == 0 and "n_unfinished" not in ds.attrs
    assert set(sf.calls(log)) == set(A) and stored(store, A) == set(A)


def test_a_dead_worker_of_a_pool_of_yours_keeps_the_finished_points_and_says_which_are_missing(tmp_path):
    from concurrent.futures import ProcessPoolExecutor

    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    sf.plan(log, exit_at=4.0)
    with pytest.raises(SweepIncomplete, match="not computed.*BrokenProcessPool") as info, \
            ProcessPoolExecutor(2) as pool:
        sweep(functools.partial(sf.logged, log=str(log)), a=A, store=store, executor=pool)
    sf.plan(log)
    err = info.value
    assert {"a": 4.0} in err.unfinished and "BrokenProcessPool" in err.reasons[0]
    part = err.dataset
    assert part.attrs["n_unfinished"] == len(err.unfinished)
    assert part.error.sel(a=4.0).item().startswith("not computed: BrokenProcessPool")
    done = [a for a in A if part.error.sel(a=a).item() == ""]
    np.testing.assert_array_equal(part.value.sel(a=done), np.array(done) + 1)
    assert stored(store, A) == set(done)
    first = sf.calls(log)
    ds = sweep(functools.partial(sf.logged, log=str(log)), a=A, store=store, workers=2)
    assert sorted(sf.calls(log)) == sorted(first + [a for a in A if a not in done])
    assert set(done) <= set(first)  # finished points were not computed again
    np.testing.assert_array_equal(ds.value, np.array(A) + 1)
    assert ds.attrs["n_failed"] == 0 and "n_unfinished" not in ds.attrs


def test_stored_failures_are_kept_unless_retry_failed(tmp_path):
    log, store = tmp_path / "log", tmp_path / "store"
    log.mkdir()
    fn = functools.partial(sf.logged, log=str(log), fail_at=1.0)
    first = sweep(fn, a=[0.0, 1.0], store=store, executor="serial")
    again = sweep(fn, a=[0.0, 1.0, 2.0], store=store, executor="serial")  # the grid grew by one point
    assert sf.calls(log) == [0.0, 1.0, 2.0]
    assert again.attrs["n_failed"] == 1 and again.error.sel(a=1.0).item() == first.error.sel(a=1.0).item()
    sweep(fn, a=[0.0, 1.0, 2.0], store=store, executor="serial", retry_failed=True)
    assert sf.calls(log) == [0.0, 1.0, 1.0, 2.0]


def test_a_store_belongs_to_one_function_and_its_fixed_arguments(tmp_path):
    sweep(sf.quadratic, a=[1.0], store=tmp_path / "one", executor="serial")
    with pytest.raises(ValueError, match="store.*quadratic"):
        sweep(sf.fails_on_negative, a=[1.0], store=tmp_path / "one", executor="serial")
    sweep(functools.partial(sf.quadratic, b=1.0), a=[1.0], store=tmp_path / "two", executor="serial")
    with pytest.raises(ValueError, match="store.*b=2.0"):
        sweep(functools.partial(sf.quadratic, b=2.0), a=[1.0], store=tmp_path / "two", executor="serial")


# ---------------------------------------------------------------------------------------
# Dask

@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # tornado's make_current, in distributed
def test_a_dask_local_cluster_gives_the_process_pool_dataset():
    distributed = pytest.importorskip("distributed")
    try:
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           dashboard_address=None, silence_logs=40)
    except Exception as exc:  # noqa: BLE001 -- no cluster on this machine: nothing to compare
        pytest.skip(f"a Dask LocalCluster cannot start here: {exc!r}")
    with cluster, distributed.Client(cluster) as client:
        on_dask = sweep(sf.critical_flow, EI=[5.0, 10.0, 20.0], client=client)
        failing = sweep(sf.fails_on_negative, a=[-1.0, 2.0], client=client)
    pooled = sweep(sf.critical_flow, EI=[5.0, 10.0, 20.0], workers=2)
    assert_same_to_round_off(on_dask, pooled, rtol=RTOL_CRITICAL)
    assert failing.attrs["n_failed"] == 1 and failing.error.values[0] == "ValueError: a = -1.0 < 0"


# ---------------------------------------------------------------------------------------
# netCDF

def test_netcdf_round_trip_keeps_values_strings_and_attrs(tmp_path):
    pytest.importorskip("netCDF4")
    ds = sweep(sf.critical_flow, EI=[5.0, -1.0, 20.0], executor="serial")  # EI < 0: a failed point
    assert ds.attrs["n_failed"] == 1 and ds.error.sel(EI=-1.0).item().startswith("ValueError")
    ds.to_netcdf(tmp_path / "flows.nc")
    back = xr.load_dataset(tmp_path / "flows.nc")
    xr.testing.assert_identical(back, ds)
    assert back.attrs["n_failed"] == 1 and back.kind.values[1] == ""


# ---------------------------------------------------------------------------------------
# bad input

def _lambda_point(a):
    return a


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(grid="cartesian", a=[1.0]), ValueError, "grid"),
    (dict(grid="zip", a=[1.0, 2.0], b=[1.0, 2.0, 3.0]), ValueError, "a: 2, b: 3"),
    (dict(), ValueError, "at least one parameter"),
    (dict(a=[]), ValueError, "'a' has no values"),
    (dict(a=[1.0, 1.0]), ValueError, "'a' repeats"),
    (dict(a=1.0), TypeError, "parameter 'a'"),
    (dict(a="abc"), TypeError, "parameter 'a'"),
    (dict(a=[None]), TypeError, "parameter 'a'"),
    (dict(error=[1.0]), ValueError, "named 'error'"),
    (dict(grid="zip", point=[1.0]), ValueError, "named 'point'"),
    (dict(a=[1.0], executor="dask"), ValueError, "executor"),
    (dict(a=[1.0], executor=4), TypeError, "executor"),
    (dict(a=[1.0], executor="serial", client=object()), ValueError, "executor= or client="),
    (dict(a=[1.0], client=object()), TypeError, "client"),
    (dict(a=[1.0], workers=0), ValueError, "workers"),
    (dict(a=[1.0], workers=2, executor="serial"), ValueError, "workers"),
])
def test_bad_input_names_the_parameter(kwargs, error, match):
    with pytest.raises(error, match=match):
        pf.sweep(sf.quadratic, progress=False, **kwargs)


def test_an_unpicklable_fn_is_a_type_error_naming_fn():
    def local(a):
        return a

    for fn in (lambda a: a, local):
        with pytest.raises(TypeError, match="fn .*cannot be pickled.*module level"):
            pf.sweep(fn, a=[1.0], progress=False)
    with pytest.raises(TypeError, match="fn must be callable"):
        pf.sweep(3.0, a=[1.0])


def test_fields_of_changing_shape_are_refused():
    with pytest.raises(ValueError, match="field 'v' with the shapes"):
        sweep(sf.ragged, a=[1, 2], executor="serial")


def test_import_pipeflex_loads_neither_dask_nor_xarray():
    code = ("import sys, pipeflex as pf; f = pf.sweep; "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'dask', 'distributed', 'xarray', 'tqdm'}), "
            "callable(f))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["[]", "True"]
