"""Distributed loads and foundations in model files (the ``distributed_loads`` key of
element, multibody and coupled files): round trips through pf.save_model and
pf.load_model, and errors naming the key."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import model_files
from pipeflex.model_files import ModelFileError
from pipeflex.multibody import MultibodyBuilder, MultibodySystem, flexible_body

SECTION = pf.PipeSection(EI=20.0, EA=1e5, GJ=15.0, pipe_mass=1.2, fluid_mass=0.3, k_found=50.0)


def element_model(*, floating=False):
    """Distributed loads given each way: element list, one element, a line; constant, a
    table and a sine."""
    b = pf.ModelBuilder()
    nodes = b.add_line(b.add_node((0.0, 0.0, 0.0)), (1.0, 0.0, 0.0), 4, SECTION)
    more = b.add_line(nodes[-1], (1.0, 0.5, 0.0), 2, SECTION)
    if not floating:
        b.clamp(nodes[0])
    b.add_distributed_load([0, 2], force_per_length=(0.0, 0.0, -3.0))
    b.add_distributed_load(1, force_per_length=(0.5, 0.0, 0.0), time_function=([0.0, 1.0], [0.2, 1.0]))
    b.add_distributed_load(line=more, force_per_length=(0.0, 1.0, -1.0),
                           time_function=pf.Sine(omega=4.0, envelope=2.0, mean=0.5))
    return b.build(floating=floating)


def body_system():
    """A body on a foundation (the section's k_found) with distributed loads, and another
    without, hinged."""
    plain = pf.PipeSection(EI=20.0, EA=1e5, GJ=15.0, pipe_mass=1.2)
    b = MultibodyBuilder()
    j0 = b.add_body(flexible_body(length=1.0, n_elements=4, section=SECTION, internal_modes=2),
                    position=(0.5, 0.0, 0.0))
    j1 = b.add_body(flexible_body(length=0.6, n_elements=2, section=plain), position=(1.3, 0.0, 0.0))
    b.hinge(j0, "end", (0.0, 0.0, 1.0), j1, "start")
    b.add_distributed_load(j0, force_per_length=(0.0, 0.0, -2.0))
    b.add_distributed_load(j1, force_per_length=(0.0, 0.7, 0.0), time_function=([0.0, 0.5], [0.0, 1.0]))
    b.add_distributed_load(j1, force_per_length=(0.1, 0.0, 0.0), time_function=pf.Pulse(start=0.1, duration=0.2))
    return b.build()


def assert_same_residuals(a, b, t=0.3):
    """Equal residual and tangent in a moved state at time t (the loads' time functions count)."""
    st = a.initial_state()
    rng = np.random.default_rng(1)
    st.r[:] += 0.01 * rng.standard_normal(st.r.shape)
    st.eta[:] += 1e-3 * rng.standard_normal(st.eta.size)
    st = type(st)(st.r, st.R, st.eta, st.v, st.a, st.lam, t)
    for x, y in zip(a.evaluate(st, mass_flow=0.0), b.evaluate(st, mass_flow=0.0)):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_element_distributed_loads_round_trip(tmp_path, suffix):
    model = element_model()
    path = pf.save_model(model, tmp_path / f"m{suffix}")
    again = pf.load_model(path)
    assert model_files._difference(model, again) is None
    a, b = pf.static_equilibrium(model), pf.static_equilibrium(again)
    assert np.array_equal(a.state.q, b.state.q)
    assert np.abs(a.state.q - model.initial_state().q).max() > 1e-3  # the loads are there
    assert pf.save_model(again, tmp_path / f"n{suffix}").read_text() == path.read_text()
    if suffix == ".yaml":
        text = path.read_text()
        for word in ("distributed_loads:", "elements: [0, 2]", "elements: 1", "line: [4, 5, 6]", "table:",
                     "sine:", "k_found: 50.0"):
            assert word in text, word


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_multibody_distributed_loads_and_foundation_round_trip(tmp_path, suffix):
    system = body_system()
    path = pf.save_model(system, tmp_path / f"b{suffix}")
    again = pf.load_model(path)
    assert isinstance(again, MultibodySystem)
    assert model_files._multibody_difference(system, again) is None
    assert again.bodies[0].foundation is not None and again.bodies[1].foundation is None
    assert_same_residuals(system, again)
    assert pf.save_model(again, tmp_path / f"c{suffix}").read_text() == path.read_text()
    if suffix == ".yaml":
        text = path.read_text()
        for word in ("distributed_loads:", "force_per_length: [0.0, 0.7, 0.0]", "pulse:", "k_found: 50.0"):
            assert word in text, word


def test_a_changed_distributed_load_is_a_difference():
    a, b = body_system(), body_system()
    desc = b._description[0]
    desc["_distributed"][0] = {**desc["_distributed"][0], "q": np.array([0.0, 0.0, -2.5])}
    assert model_files._multibody_difference(a, b) == "distributed"


def test_coupled_distributed_loads_round_trip(tmp_path):
    model = element_model(floating=True)
    bodies = MultibodyBuilder()
    hub = bodies.add_body_between(flexible_body(length=0.2, n_elements=2, section=SECTION), (-0.2, 0.0, 0.0),
                                  (0.0, 0.0, 0.0))
    bodies.fix(hub, "start")
    bodies.add_distributed_load(hub, force_per_length=(0.0, -1.0, 0.0))
    system = pf.CoupledSystem(model, bodies.build())
    system.rigid(0, hub, "end")
    path = pf.save_model(system, tmp_path / "c.yaml")
    again = pf.load_model(path)
    assert model_files._coupled_difference(system, again) is None
    assert path.read_text().count("distributed_loads:") == 2  # the elements' and the bodies'
    assert pf.save_model(again, tmp_path / "d.yaml").read_text() == path.read_text()


def write(tmp_path, text, name="m.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


ELEMENTS = """\
sections:
  s: {EI: 20.0, pipe_mass: 1.2}
geometry:
  - node: [0, 0, 0]
  - line: {start: 0, end: [1, 0, 0], n_elements: 2, section: s}
supports:
  - clamp: 0
distributed_loads:
  - {elements: [0, 1], force_per_length: [0, 0, -1]}
"""


def test_a_hand_written_distributed_load_is_the_builders(tmp_path):
    model = pf.load_model(write(tmp_path, ELEMENTS))
    b = pf.ModelBuilder()
    nodes = b.add_line(b.add_node((0.0, 0.0, 0.0)), (1.0, 0.0, 0.0), 2, pf.PipeSection(EI=20.0, pipe_mass=1.2))
    b.clamp(nodes[0])
    b.add_distributed_load([0, 1], force_per_length=(0.0, 0.0, -1.0))
    q = pf.static_equilibrium(model).state.q
    assert np.array_equal(q, pf.static_equilibrium(b.build()).state.q)
    assert q[6 * 2 + 2] == pytest.approx(-1.0 / (8 * 20.0), rel=1e-3)  # q L^4 / (8 EI), small


@pytest.mark.parametrize("change, key, message", [
    ("elements: [0, 1]", "distributed_loads[0].elements[1]", "a body index"),
    ("elements: [0, 7]", "distributed_loads[0]", "elements refers to pipe element 7"),
    ("force_per_length: [0, 0]", "distributed_loads[0].force_per_length", "3 numbers"),
    ("force_per_lenght: [0, 0, -1]", "distributed_loads[0].force_per_lenght", "force_per_length"),
])
def test_distributed_load_errors_name_the_key(tmp_path, change, key, message):
    old = {"elements: [0, 1]": "elements: [0, 1]", "elements: [0, 7]": "elements: [0, 1]",
           "force_per_length: [0, 0]": "force_per_length: [0, 0, -1]",
           "force_per_lenght: [0, 0, -1]": "force_per_length: [0, 0, -1]"}[change]
    text = ELEMENTS.replace(old, change.replace("[0, 1]", "[0, -1]") if change == "elements: [0, 1]" else change)
    with pytest.raises(ModelFileError) as err:
        pf.load_model(write(tmp_path, text))
    assert f", {key}: " in str(err.value) and message in str(err.value), str(err.value)


# -- the models' own save methods -------------------------------------------------------


def test_model_save_writes_the_file_save_model_writes(tmp_path):
    model = element_model()
    path = model.save(tmp_path / "own.yaml")
    assert path == tmp_path / "own.yaml"
    assert path.read_text() == pf.save_model(model, tmp_path / "pf.yaml").read_text()
    assert model_files._difference(model, pf.load_model(path)) is None
    with pytest.raises(ValueError, match="a model file ends in"):
        model.save(tmp_path / "own.txt")


def test_model_save_and_save_model_agree_on_every_kind_of_entry(tmp_path):
    """Model.save checks the file's grouping by building the calls in the file's order
    (pipeflex.model_writer.ELEMENT_ORDER), save_model by reading the text back: on a model
    with every kind of entry both accept and write the same text."""
    from test_model_files import rich_model

    model = rich_model()
    assert model.save(tmp_path / "a.json").read_text() == pf.save_model(model, tmp_path / "b.json").read_text()


def test_body_and_coupled_save_write_the_files_save_model_writes(tmp_path):
    system = body_system()
    assert system.save(tmp_path / "b.json").read_text() == pf.save_model(system, tmp_path / "c.json").read_text()
    assert_same_residuals(system, pf.load_model(tmp_path / "b.json"))
    coupled, _, _ = pf.scenes.sprinkler_on_hub(n_elements=4)
    text = coupled.save(tmp_path / "s.yaml").read_text()
    assert text == pf.save_model(coupled, tmp_path / "t.yaml").read_text()
    assert model_files._coupled_difference(coupled, pf.load_model(tmp_path / "s.yaml")) is None


def test_model_save_refuses_an_order_the_file_cannot_keep(tmp_path):
    """(As pf.save_model: tests/test_model_files.py.) A reservoir inlet marks only the
    elements from its node made before it; the file lists the inlets after the geometry."""
    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0, fluid_mass=0.5)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 2, sec)
    b.reservoir_inlet(n0)
    b.add_line(n0, (0.0, 1.0, 0.0), 2, sec)
    b.clamp(n0)
    with pytest.raises(ValueError, match="would not rebuild it exactly .the elements differ"):
        b.build().save(tmp_path / "m.yaml")
    assert not (tmp_path / "m.yaml").exists()


def test_saving_from_the_model_loads_no_reader(tmp_path):
    """Model.save needs only the writer (no import cycle model -> model_files -> model)."""
    import subprocess
    import sys

    code = ("import sys, pipeflex as pf\n"
            "b = pf.ModelBuilder(); n = b.add_line(b.add_node((0, 0, 0)), (1, 0, 0), 2, "
            "pf.PipeSection(EI=1.0, pipe_mass=1.0)); b.clamp(n[0])\n"
            f"b.build().save({str(tmp_path / 'm.json')!r})\n"
            "print('pipeflex.model_files' in sys.modules, 'pipeflex.model_writer' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "True"]
    assert pf.load_model(tmp_path / "m.json").n_nodes == 3
