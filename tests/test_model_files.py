"""Model files (pf.load_model, pf.save_model): round trips, the seeds' files, errors naming
file, line and key."""
import pickle
from pathlib import Path

import numpy as np
import pytest

import pipeflex as pf
from pipeflex.model_files import ModelFileError

MODELS = Path(pf.__file__).parent / "seeds" / "models"


def assert_same_linearization(a, b, *, ulps=4):
    """The two models' M, C, K agree to a few ulps of their largest entry, with the same labels."""
    la, lb = pf.linearize(a), pf.linearize(b)
    assert la.dof_labels == lb.dof_labels
    for name in ("M", "C", "K"):
        A, B = getattr(la, name).toarray(), getattr(lb, name).toarray()
        scale = max(np.abs(A).max(), np.abs(B).max(), np.finfo(float).tiny)
        assert np.abs(A - B).max() <= ulps * np.spacing(scale), name


def assert_same_model(a, b):
    assert np.array_equal(a.positions, b.positions)
    assert [e.section for e in a.elements] == [e.section for e in b.elements]
    assert [(e.nodes, e.length, e.flow_factor, e.kind, e.elastic) for e in a.elements] == \
           [(e.nodes, e.length, e.flow_factor, e.kind, e.elastic) for e in b.elements]
    assert a.dof_labels == b.dof_labels and a.springs == b.springs
    assert np.array_equal(a.gravity, b.gravity) and a.mass_flow == b.mass_flow
    assert (a.basis != b.basis).nnz == 0
    assert_same_linearization(a, b)


def rich_model():
    """Every kind of entry: nodes, line, arc, pipe, supports of each kind, springs, masses,
    loads (dead and follower), gravity, a reservoir inlet, a tube section, a shear section."""
    tube = pf.PipeSection.tube(outer_diameter=0.05, inner_diameter=0.04, E=2e11, G=8e10, density=7800.0,
                               fluid_density=1000.0, rotary_inertia=True)
    shear = pf.PipeSection(EI=2e3, pipe_mass=3.0, fluid_mass=0.5, EIz=3e3, GAy=1e6, GAz=2e6, kv=1.2)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    line = b.add_line(n0, (1.0, 0.0, 0.0), 3, tube, up=(0.0, 1.0, 1.0))
    arc = b.add_arc(line[-1], center=(1.0, 0.5, 0.0), angle=np.pi / 2, normal=(0.0, 0.0, 1.0), n_elements=3,
                    section=tube)
    n5 = b.add_node((1.5, 1.5, 0.0))
    b.add_pipe(arc[-1], n5, shear, flow_factor=1.0)
    b.reservoir_inlet(n0)
    b.clamp(n0)
    b.hinge(n5, (0.0, 0.0, 1.0))
    b.fix(line[1], "uz")
    b.axial_support(line[2], (0.0, 1.0, 0.0))
    b.fix_rotation(arc[1], (1.0, 0.0, 0.0))
    b.add_spring(line[1], arc[2], stiffness=5e3, damping=2.0)
    b.add_ground_spring(arc[1], stiffness=(1e4, 0.0, 2e4), anchor=(1.2, 0.1, 0.0), rotational_stiffness=(0, 0, 50.0))
    b.add_point_mass(line[2], 0.7, (1e-3, 2e-3, 3e-3))
    b.add_load(arc[2], force=(0.0, 0.0, -10.0))
    b.add_load(arc[3], force=(1.0, 0.0, 0.0), moment=(0.0, 0.5, 0.0), follower=True)
    b.set_gravity((0.0, 0.0, -9.81))
    return b.build(mass_flow=1.5)


@pytest.mark.parametrize("suffix", [".yaml", ".yml", ".json"])
def test_round_trip_reproduces_the_model(tmp_path, suffix):
    model = rich_model()
    path = pf.save_model(model, tmp_path / f"m{suffix}")
    again = pf.load_model(path)
    assert_same_model(model, again)
    # and the file written from the loaded model is the same text
    assert pf.save_model(again, tmp_path / f"n{suffix}").read_text() == path.read_text()


def test_round_trip_static_solution(tmp_path):
    model = rich_model()
    again = pf.load_model(pf.save_model(model, tmp_path / "m.yaml"))
    a, b = pf.static_equilibrium(model), pf.static_equilibrium(again)
    assert np.abs(a.state.q - b.state.q).max() <= 8 * np.spacing(np.abs(a.state.q).max())


def test_ancf_hub_and_floating_round_trip(tmp_path):
    beam = pf.scenes.rotating_cantilever(n_elements=4, omega=3.0, spin_up_time=2.0, tip_mass_ratio=0.2,
                                         hub_radius_ratio=0.5, elastic="0")
    again = pf.load_model(pf.save_model(beam, tmp_path / "beam.json"))
    assert_same_model(beam, again)
    for name in ("nodes", "axis", "center", "omega", "spin_up_time"):
        assert np.array_equal(getattr(again.hub, name), getattr(beam.hub, name))
    assert again.info["beam_nodes"] == list(beam.info["beam_nodes"])
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 2, pf.PipeSection(EI=1.0, pipe_mass=1.0))
    floating = b.build(floating=True)
    text = pf.save_model(floating, tmp_path / "f.yaml").read_text()
    assert "floating: true" in text
    assert pf.load_model(tmp_path / "f.yaml").n_dofs == 18
    # a pickled floating model rebuilds as floating
    assert pickle.loads(pickle.dumps(floating)).n_dofs == 18


SEEDS = {
    "cantilever_pipe": lambda: pf.scenes.cantilever_pipe(n_elements=10),
    "sprinkler": lambda: pf.scenes.sprinkler(EI=10.0),
    "coriolis_meter": lambda: pf.scenes.coriolis_meter(leg_length=0.495),
    "rotating_cantilever": lambda: pf.scenes.rotating_cantilever(),
}


def test_every_seed_file_is_tested():
    # element models (the files of bodies and coupled systems: tests/test_model_files_bodies.py)
    assert {p.stem for p in MODELS.glob("*.yaml") if "\nkind: " not in p.read_text()} == set(SEEDS)


@pytest.mark.parametrize("name", sorted(SEEDS))
def test_seed_files_load_equal_to_their_scenes(name):
    from_file, built = pf.load_model(MODELS / f"{name}.yaml"), SEEDS[name]()
    assert_same_model(from_file, built)
    if name == "coriolis_meter":  # and the same static solution under a load
        ls = pf.static_equilibrium(from_file, mass_flow=5.0)
        lb = pf.static_equilibrium(built, mass_flow=5.0)
        assert np.abs(ls.state.q - lb.state.q).max() <= 8 * np.spacing(np.abs(lb.state.q).max())


BASE = """\
sections:
  s: {EI: 1.0, pipe_mass: 1.0}
geometry:
  - node: [0, 0, 0]
  - line: {start: 0, end: [1, 0, 0], n_elements: 4, section: s}
supports:
  - clamp: 0
"""


def load_text(tmp_path, text, name="m.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return pf.load_model(path)


def test_hand_written_file(tmp_path):
    """YAML 1.1 reads 1e10 as text: numbers in that form are accepted; a tube section."""
    model = load_text(tmp_path, """\
# a cantilever of two sections
sections:
  s: {EI: 1.0, pipe_mass: 1.0, EA: 1e10}
  t: {tube: {outer_diameter: 0.05, inner_diameter: 0.04, E: 2e11, G: 8e10, density: 7800}}
geometry:
  - node: [0, 0, 0]
  - line: {start: 0, end: [1, 0, 0], n_elements: 4, section: s}
  - line: {start: 4, end: [2, 0, 0], n_elements: 2, section: t}
supports:
  - clamp: 0
""")
    assert model.n_nodes == 7 and model.elements[0].section.EA == 1e10
    assert model.elements[-1].section == pf.PipeSection.tube(outer_diameter=0.05, inner_diameter=0.04, E=2e11,
                                                             G=8e10, density=7800.0)


@pytest.mark.parametrize("change, line, key, message", [
    (("n_elements: 4", "n_elemnts: 4"), 5, "geometry[1].line.n_elemnts", "did you mean 'n_elements'"),
    (("n_elements: 4", "n_elements: four"), 5, "geometry[1].line.n_elements", "must be an integer >= 1"),
    ((", n_elements: 4", ""), 5, "geometry[1].line", "missing required key 'n_elements'"),
    (("start: 0", "start: 7"), 5, "geometry[1].line.start", "unknown node 7"),
    (("section: s}", "section: steel}"), 5, "geometry[1].line.section", "unknown section 'steel'"),
    (("  - clamp: 0\n", "  - clamp: 0\nsprings:\n  - axial: {node_a: 1, node_b: 4, stiffness: -1e3}\n"), 9,
     "springs[0].axial.stiffness", "must be a number >= 0, got -1000"),
    (("  - clamp: 0\n", "  - clamp: 0\ngravty: [0, 0, -9.81]\n"), 8, "gravty", "did you mean 'gravity'"),
    (("  - clamp: 0\n", "  - clmp: 0\n"), 7, "supports[0].clmp", "did you mean 'clamp'"),
    (("[1, 0, 0]", "[1, 0]"), 5, "geometry[1].line.end", "must be 3 numbers"),
    (("  - clamp: 0\n", "  - hinge: {node: 0, axis: [0, 0, 0]}\n"), 7, "supports[0].hinge",
     "axis must be a non-zero vector"),
])
def test_errors_name_file_line_and_key(tmp_path, change, line, key, message):
    with pytest.raises(ModelFileError) as info:
        load_text(tmp_path, BASE.replace(*change))
    text = str(info.value)
    assert text.startswith(f"{tmp_path / 'm.yaml'}, line {line}, {key}: "), text
    assert message in text
    assert (info.value.line, info.value.key) == (line, key)


def test_json_errors_have_lines_too(tmp_path):
    model = rich_model()
    text = pf.save_model(model, tmp_path / "m.json").read_text().replace('"n_elements": 3', '"n_elements": -3', 1)
    with pytest.raises(ModelFileError, match=r"m\.json, line \d+, geometry\[1\]\.line\.n_elements: must be an "
                                             r"integer >= 1, got -3"):
        load_text(tmp_path, text, "m.json")


def test_file_level_errors(tmp_path):
    with pytest.raises(ModelFileError, match="missing required key 'geometry'"):
        load_text(tmp_path, "sections: {}\n")
    with pytest.raises(ModelFileError, match=r"m\.yaml, line \d+: not valid YAML"):
        load_text(tmp_path, "geometry:\n  - node: [0, 0\n")
    with pytest.raises(ModelFileError, match="the key 'geometry' appears twice"):
        load_text(tmp_path, BASE + "geometry: []\n")
    with pytest.raises(ModelFileError, match="no supports"):
        load_text(tmp_path, BASE.replace("supports:\n  - clamp: 0\n", ""))
    with pytest.raises(ValueError, match="ends in .yaml, .yml, .json"):
        pf.load_model(tmp_path / "m.txt")
    with pytest.raises(FileNotFoundError, match="no such model file"):
        pf.load_model(tmp_path / "missing.yaml")


def test_save_refuses_what_it_cannot_write(tmp_path):
    model = rich_model()
    with pytest.raises(ValueError, match="free_model"):
        pf.save_model(model.free_model(), tmp_path / "f.yaml")
    with pytest.raises(ValueError, match="ends in"):
        pf.save_model(model, tmp_path / "m.txt")
    (tmp_path / "d.yaml").mkdir()
    with pytest.raises(ValueError, match="is a folder"):
        pf.save_model(model, tmp_path / "d.yaml")


def test_recipe_is_what_the_caller_passed_then(tmp_path):
    """A list changed after the call does not change the recorded call; a failed call is not recorded."""
    b = pf.ModelBuilder()
    p = [0.0, 0.0, 0.0]
    n0 = b.add_node(p)
    p[0] = 5.0
    with pytest.raises(ValueError):
        b.add_line(n0, (1.0, 0.0, 0.0), 0, pf.PipeSection(EI=1.0, pipe_mass=1.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 2, pf.PipeSection(EI=1.0, pipe_mass=1.0))
    b.clamp(n0)
    model = b.build()
    assert [c[0] for c in model._description["_recipe"]] == ["add_node", "add_line", "clamp"]
    assert_same_model(model, pf.load_model(pf.save_model(model, tmp_path / "m.yaml")))


def test_save_refuses_an_order_the_file_cannot_keep(tmp_path):
    """A reservoir inlet marks the elements that start at its node when it is called: a
    later element from that node is not marked, which the file (inlets after the geometry)
    cannot say. Saving refuses rather than write a different model."""
    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0, fluid_mass=0.5)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 2, sec)
    b.reservoir_inlet(n0)
    b.add_line(n0, (0.0, 1.0, 0.0), 2, sec)
    b.clamp(n0)
    with pytest.raises(ValueError, match="would not rebuild it exactly .the elements differ"):
        pf.save_model(b.build(), tmp_path / "m.yaml")
    assert not (tmp_path / "m.yaml").exists()


def test_damping_round_trips(tmp_path):
    """Kelvin-Voigt and viscous section damping and Rayleigh damping are model-file data:
    the reloaded model has the same damping matrix C (zero flow: C is damping alone)."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    section = pf.PipeSection(EI=10.0, pipe_mass=1.0, eta_bending=2e-3, eta_axial=1e-3, c_ext=0.3)
    b.add_line(n0, (1.0, 0.0, 0.0), 3, section)
    b.clamp(n0)
    b.rayleigh_damping(alpha=0.2, beta=1e-4)
    model = b.build()
    again = pf.load_model(pf.save_model(model, tmp_path / "damped.yaml"))
    C0, C1 = pf.linearize(model).C.toarray(), pf.linearize(again).C.toarray()
    assert np.abs(C0).max() > 0
    np.testing.assert_array_equal(C0, C1)
    text = (tmp_path / "damped.yaml").read_text()
    assert "rayleigh_damping" in text and "eta_bending" in text
    bad = text.replace("eta_bending: 0.002", "eta_bending: -0.002")
    (tmp_path / "bad.yaml").write_text(bad)
    with pytest.raises(ValueError, match="eta_bending"):
        pf.load_model(tmp_path / "bad.yaml")
