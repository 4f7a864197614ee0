"""Result contract (save/load/pickle/to_dict) and pickling of models and systems."""
import copy
import dataclasses
import pickle

import numpy as np
import pytest
import scipy.sparse as sp

import pipeflex as pf
from pipeflex import _core
from pipeflex import multibody as mb
from pipeflex.results import Result
from pipeflex.state import State


def assert_same(a, b, where="result"):
    """Exact equality: same types, dtypes, shapes and bits."""
    assert type(a) is type(b), f"{where}: {type(a).__name__} != {type(b).__name__}"
    if isinstance(a, Result):
        for f in dataclasses.fields(a):
            assert_same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert a.tobytes() == b.tobytes(), where
    elif isinstance(a, np.generic):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), where
    elif sp.issparse(a):
        assert a.shape == b.shape, where
        for p in ("row", "col", "data") if a.format == "coo" else ("data", "indices", "indptr"):
            assert_same(getattr(a, p), getattr(b, p), f"{where}.{p}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            assert_same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, (float, complex)):
        assert np.asarray(a).tobytes() == np.asarray(b).tobytes(), f"{where}: {a!r} != {b!r}"
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


def loaded_model():
    """A clamped pipe with a curved part, gravity, dead and follower loads, a point mass,
    a reservoir inlet and rotary inertia: most of what a builder records."""
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, rotary_inertia=(1e-3, 1e-4, 1e-4))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    line = b.add_line(n0, (0.5, 0.0, 0.0), 2, sec)
    arc = b.add_arc(line[-1], center=(0.5, 0.3, 0.0), angle=np.pi / 4, normal=(0.0, 0.0, 1.0), n_elements=2,
                    section=sec)
    b.clamp(n0)
    b.reservoir_inlet(n0)
    b.set_gravity((0.0, 0.0, -9.81))
    b.add_load(arc[-1], force=(0.0, 1.0, 2.0))
    b.add_load(line[1], moment=(0.1, 0.0, 0.0), follower=True)
    b.add_point_mass(arc[-1], 0.3, (1e-4, 1e-4, 1e-4))
    m = b.build(mass_flow=2.0)
    m.info.update(note="test", tip=arc[-1])
    return m


def small_system():
    """Two floating-frame bodies: a hinge driven by a Sine torque, a tabled load."""
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, rotary_inertia=(1e-3, 1e-4, 1e-4))
    body = mb.flexible_body(length=0.5, n_elements=4, section=sec, internal_modes=1)
    bent = mb.flexible_body(length=0.5, n_elements=4, section=sec, curvature=0.5)
    b = mb.MultibodyBuilder()
    j0 = b.add_body(body, position=(0.25, 0.0, 0.0))
    start = np.array([bent.nodes_s[0], 0.0, 0.0]) + bent.basis[0:3] @ bent.eta0  # in the body frame
    j1 = b.add_body(bent, position=np.array([0.5, 0.0, 0.0]) - start)
    b.hinge(j0, "start", (0.0, 0.0, 1.0), torque=pf.Sine(omega=3.0, envelope=([0.0, 1.0], [0.0, 2.0])))
    b.rigid(j0, "end", j1, "start")
    b.add_load(j1, "end", force=(0.0, ([0.0, 0.5], [0.0, 1.0]), -1.0))
    b.set_gravity((0.0, 0.0, -9.81))
    s = b.build(mass_flow=1.0)
    s.info.update(scene="test")
    return s


@pytest.fixture(scope="module")
def results():
    m = loaded_model()
    static = pf.static_equilibrium(m, load_steps=2)
    lin = pf.linearize(m, static.state)
    transient = pf.simulate(m, 0.01, integrator="generalized_alpha", step=2e-3, state=static.state, n_outputs=4,
                            progress=False)
    s = pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.0)
    mb_static = mb.static_equilibrium(s)
    return {
        "state": static.state,
        "static": static,
        "linearization": lin,
        "eigen": pf.eigenvalues(lin, vectors=True),
        "critical": pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=4)),
        "steady": pf.steady_rotation(pf.scenes.sprinkler(EI=100.0)),
        "coupled_steady": pf.steady_rotation(pf.scenes.sprinkler_on_hub()[0]),
        "rotating": pf.rotating_frequencies(pf.scenes.rotating_cantilever(n_elements=4), gamma=[0.0, 1.0, 2.0],
                                            n_modes=2),
        "transient": transient,
        "mb_static": mb_static,
        "mb_state": mb_static.state,
        "mb_linearization": mb.linearize(s, mb_static.state),
        "mb_transient": mb.simulate(s, 0.01, step=1e-3, state=mb_static.state, n_outputs=5, mass_flow=1.0),
    }


NAMES = ["state", "static", "linearization", "eigen", "critical", "steady", "coupled_steady", "rotating", "transient",
         "mb_static", "mb_state", "mb_linearization", "mb_transient"]


def _walk(x):
    """Every value inside a result (depth first)."""
    yield x
    if isinstance(x, Result):
        for f in dataclasses.fields(x):
            yield from _walk(getattr(x, f.name))
    elif isinstance(x, (list, tuple)):
        for v in x:
            yield from _walk(v)
    elif isinstance(x, dict):
        for v in x.values():
            yield from _walk(v)


@pytest.mark.parametrize("name", NAMES)
def test_results_are_frozen_plain_data(results, name):
    r = results[name]
    assert isinstance(r, Result) and dataclasses.is_dataclass(r)
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(r, dataclasses.fields(r)[0].name, None)
    for v in _walk(r):
        assert type(v).__module__.split(".")[0] != "pipeflex._core", f"{name} holds a C++ {type(v).__name__}"
        assert not isinstance(v, (pf.Model, mb.MultibodySystem))


@pytest.mark.parametrize("name", NAMES)
def test_save_load_round_trip(results, name, tmp_path):
    r = results[name]
    path = tmp_path / "not" / "yet" / f"{name}.npz"
    assert r.save(path) == path
    assert_same(r, type(r).load(path))
    assert_same(r, Result.load(path))


@pytest.mark.parametrize("name", NAMES)
def test_pickle_round_trip(results, name):
    r = results[name]
    assert_same(r, pickle.loads(pickle.dumps(r)))
    assert_same(r, copy.deepcopy(r))


@pytest.mark.parametrize("name", NAMES)
def test_to_dict(results, name):
    r = results[name]
    d = r.to_dict()
    assert list(d) == [f.name for f in dataclasses.fields(r)]
    for v in _walk(d):
        assert not isinstance(v, Result)


def test_to_dict_nests_results(results):
    d = results["static"].to_dict()
    assert isinstance(d["state"], dict) and d["state"]["q"] is results["static"].state.q
    assert isinstance(results["eigen"].to_dict()["blocks"][0], dict)


def test_existing_attributes_and_methods(results):
    tr = results["transient"]
    assert np.array_equal(tr.angle(0), tr.angle(0)) and tr.energy.shape == tr.t.shape
    assert results["static"].state.frame(0).shape == (3, 3)
    assert results["rotating"].transverse.shape == (3, 2)
    assert results["critical"].kind == "flutter" and isinstance(results["critical"].eigenvalue, complex)
    res = results["mb_transient"]
    st = res.state(len(res.t) - 1)
    s = pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.0)
    assert res.n_coordinates == s.n_coordinates and res.n_constraints == s.n_constraints
    for node in ("start", "center", "end", 1):
        assert res.node_position(1, node)[-1] == pytest.approx(s.node_position(st, 1, node), abs=1e-14)
    assert res.node_angular_velocity(1, "end").shape == (len(res.t), 3)
    with pytest.raises(ValueError, match="body must be in"):
        res.node_position(2, "end")


def test_save_appends_npz_and_load_finds_it(results, tmp_path):
    path = results["static"].save(tmp_path / "static")
    assert path.name == "static.npz" and path.exists()
    assert_same(results["static"], pf.StaticResult.load(tmp_path / "static"))


def test_load_checks_the_class(results, tmp_path):
    path = results["static"].save(tmp_path / "s.npz")
    with pytest.raises(TypeError, match="holds a StaticResult, not a TransientResult"):
        pf.TransientResult.load(path)


def test_legacy_transient_file(results, tmp_path):
    import json

    r = results["transient"]
    path = tmp_path / "old.npz"
    np.savez(path, **{k: getattr(r, k) for k in r._ARRAYS}, stats=json.dumps(r.stats),
             metadata=json.dumps(r.metadata))
    assert_same(dataclasses.replace(r, final_state=None), pf.TransientResult.load(path))  # not in old files


@dataclasses.dataclass(frozen=True)
class Everything(Result):
    a: object
    b: object = None


def test_save_values_of_every_supported_kind(tmp_path):
    value = {"f": -0.0, "nan": float("nan"), "inf": -np.inf, "c": 1 + 2j, "i": 2**70, "b": True, "n": None,
             "s": "x", 3: (1, [2.5, "y"]), (1, 2): np.float32(1.5), "u": np.arange(3, dtype=np.uint8),
             "cplx": np.array([1j, 2]), "fortran": np.asfortranarray(np.ones((2, 3))), "empty": np.zeros((0, 2)),
             "csr": sp.csr_matrix(np.eye(3)), "coo": sp.coo_matrix(np.eye(2)), "str": np.array(["ab", "c"])}
    r = Everything(value, Everything([np.int64(3), np.bool_(True)]))
    path = r.save(tmp_path / "e.npz", compress=True)
    assert_same(r, Everything.load(path))
    assert_same(r, pickle.loads(pickle.dumps(r)))


def test_unsupported_values_are_refused(tmp_path):
    @dataclasses.dataclass(frozen=True)
    class Bad(Result):
        a: object

    with pytest.raises(TypeError, match=r"Bad\.a: cannot save a Model"):
        Bad(loaded_model()).save(tmp_path / "bad.npz")
    with pytest.raises(TypeError, match="arrays of Python objects"):
        Bad(np.array([object()])).save(tmp_path / "bad.npz")


# -- State ---------------------------------------------------------------------------

def test_state_converts_exactly_and_analyses_accept_both_kinds(results):
    m = loaded_model()
    st = results["static"].state
    core = st.to_core(m)
    assert isinstance(core, _core.State)
    assert_same(st, State.from_core(core, m))
    for i in range(m.n_nodes):
        assert np.allclose(st.rotation(i), core.rotation(i), rtol=0, atol=1e-15)
    r = pf.scenes.rotating_cantilever(n_elements=2)
    spun = pf.rotating_state(r, 3.0)
    for i in range(r.n_nodes):
        assert np.allclose(State.from_core(spun, r).rotation(i), spun.rotation(i), rtol=0, atol=1e-15)
    a = pf.linearize(m, st)
    b = pf.linearize(m, core)
    assert_same(a, b)
    assert_same(pf.static_equilibrium(m, state=st), pf.static_equilibrium(m, state=core))
    with pytest.raises(ValueError, match="state.q must have shape"):
        pf.linearize(pf.scenes.cantilever_pipe(n_elements=2), st)
    with pytest.raises(ValueError, match="state has 18 coordinates, the model 30"):
        pf.linearize(pf.scenes.cantilever_pipe(n_elements=4), spun)
    with pytest.raises(ValueError, match="state must be"):
        pf.linearize(m, np.zeros(6 * m.n_nodes))


# -- models and systems ------------------------------------------------------------------

def _pickled(x):
    return pickle.loads(pickle.dumps(x))


def _model_analyses(m):
    out = {"lin": pf.linearize(m)}
    if m.hub is None and not m.ancf_nodes:
        st = pf.static_equilibrium(m, load_steps=2)
        out.update(static=st, lin_static=pf.linearize(m, st.state),
                   run=pf.simulate(m, 0.006, integrator="generalized_alpha", step=2e-3, state=st.state, n_outputs=4,
                                   progress=False))
    return out


def _same_run(a, b):
    for k in a._ARRAYS:
        assert_same(getattr(a, k), getattr(b, k), k)


@pytest.mark.parametrize("make", [loaded_model, lambda: pf.scenes.cantilever_pipe(n_elements=4, mass_flow=3.0, polar_inertia=1e-3),
                                  lambda: pf.scenes.rotating_cantilever(n_elements=4, tip_mass_ratio=0.5)])
@pytest.mark.parametrize("copier", [_pickled, copy.deepcopy])
def test_models_pickle_and_deepcopy(make, copier):
    m = make()
    m2 = copier(m)
    assert m2 is not m and m2.core is not m.core
    assert m2.info == m.info and m2.mass_flow == m.mass_flow and m2.dof_labels == m.dof_labels
    assert_same(m.positions, m2.positions)
    a, b = _model_analyses(m), _model_analyses(m2)
    for k in a:
        if k == "run":
            _same_run(a[k], b[k])
        else:
            assert_same(a[k], b[k], k)
    assert_same(pf.linearize(m.free_model()), pf.linearize(copier(m.free_model())))
    if m.hub is not None:
        g = [0.0, 1.0]
        assert_same(pf.rotating_frequencies(m, gamma=g), pf.rotating_frequencies(m2, gamma=g))


def test_sprinkler_copy_gives_the_same_steady_rotation():
    m = pf.scenes.sprinkler(EI=100.0)
    m2 = _pickled(m)
    assert_same(pf.steady_rotation(m), pf.steady_rotation(m2))


@pytest.mark.parametrize("make", [small_system,
                                  lambda: pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4,
                                                                          tip_force=1.0)])
@pytest.mark.parametrize("copier", [_pickled, copy.deepcopy])
def test_systems_pickle_and_deepcopy(make, copier):
    s = make()
    s2 = copier(s)
    assert s2 is not s and s2.core is not s.core
    assert s2.info == s.info and s2.mass_flow == s.mass_flow and s2.n_dofs == s.n_dofs
    assert_same(s.initial_state(), s2.initial_state())
    # at rest: small_system's flow turns its hinge (the jet's reaction at the bent end, a sprinkler),
    # there is no static equilibrium with it
    st, st2 = (mb.static_equilibrium(x, load_steps=2, mass_flow=0.0) for x in (s, s2))
    assert_same(st, st2)
    assert_same(mb.linearize(s, st.state), mb.linearize(s2, st2.state))
    runs = [mb.simulate(x, 0.005, step=1e-3, state=st.state, n_outputs=6) for x in (s, s2)]
    for k in ("t", "r", "R", "eta", "v", "drift", "offsets", "n_constraints", "nodes_s", "bases"):
        assert_same(getattr(runs[0], k), getattr(runs[1], k), k)


def test_flexible_body_pickles():
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0)
    body = mb.flexible_body(length=0.5, n_elements=4, section=sec, internal_modes=2, curvature=0.3)
    for b2 in (_pickled(body), copy.deepcopy(body)):
        assert b2 is not body and b2.data is not body.data
        for k in ("nodes_s", "basis", "eta0"):
            assert_same(getattr(body, k), getattr(b2, k), k)
        for k in ("M", "K", "Ng", "eta0"):
            assert_same(np.asarray(getattr(body.data, k)), np.asarray(getattr(b2.data, k)), k)
