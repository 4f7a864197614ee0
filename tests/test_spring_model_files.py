"""Spring-dampers in model files: the bushings of element models (``springs: - bushing``),
the springs of ``kind: multibody`` (axial, ground, bushing) and the coupling springs of
``kind: coupled`` (``couplings: - axial``, ``- bushing``) round-trip: load(save(m)) is the
builder's system, bit for bit, and the file's text is stable."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import model_files
from pipeflex.coupled import CoupledSystem
from pipeflex.multibody import MultibodyBuilder, flexible_body
from pipeflex.rotation import rotation_exp

SEC = pf.PipeSection(EI=50.0, EA=1e4, GJ=40.0, pipe_mass=1.0, rotary_inertia=(1e-3, 5e-4, 5e-4))


def bodies_with_springs():
    mb = MultibodyBuilder()
    j0 = mb.add_body(flexible_body(length=0.5, n_elements=2, section=SEC), position=(0.25, 0.0, 0.0))
    R = rotation_exp([0.0, 0.0, 0.3])
    j1 = mb.add_body(flexible_body(length=0.5, n_elements=2, section=SEC), position=(0.5, 0.0, 0.0) + R @ (0.25, 0, 0),
                     rotation=R)
    mb.fix(j0, "start")
    mb.add_spring(j0, "center", j1, "end", stiffness=30.0, damping=0.5)
    mb.add_ground_spring(j1, "end", stiffness=(1.0, 2.0, 3.0), anchor=(0.9, 0.3, 0.0),
                         rotational_damping=(0.0, 0.1, 0.0))
    mb.add_bushing(j0, "end", j1, 0, stiffness=(1e3, 2e3, 3e3), damping=(1.0, 0.0, 2.0),
                   rotational_stiffness=(5.0, 6.0, 7.0))
    return mb


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_element_model_bushings_round_trip(tmp_path, suffix):
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    tip = b.add_line(n0, (1.0, 0.0, 0.0), 2, SEC)[-1]
    other = b.add_node((1.0, 0.0, 0.0))
    b.add_line(other, (2.0, 0.0, 0.0), 2, SEC)
    b.clamp(n0)
    b.add_bushing(tip, other, stiffness=(1e4, 1e4, 1e4), rotational_stiffness=(30.0, 40.0, 0.0),
                  rotational_damping=(0.0, 0.0, 0.2))
    model = b.build()
    path = pf.save_model(model, tmp_path / f"m{suffix}")
    assert "bushing" in path.read_text()
    again = pf.load_model(path)
    assert model_files._difference(model, again) is None
    assert again.springs == model.springs and again.springs[0].kind == "bushing"
    assert pf.save_model(again, tmp_path / f"again{suffix}").read_text() == path.read_text()


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_body_springs_round_trip(tmp_path, suffix):
    system = bodies_with_springs().build()
    path = pf.save_model(system, tmp_path / f"bodies{suffix}")
    again = pf.load_model(path)
    assert model_files._multibody_difference(system, again) is None
    st = system.initial_state()
    st.v[:] = np.linspace(-1.0, 1.0, st.v.size)  # moving: the dampers count too
    for x, y in zip(system.evaluate(st, mass_flow=0.0), again.evaluate(st, mass_flow=0.0)):
        np.testing.assert_array_equal(x, y)
    assert system.spring_energy(st) == again.spring_energy(st)
    assert pf.save_model(again, tmp_path / f"again{suffix}").read_text() == path.read_text()
    # the check can fail: a different spring is a difference
    other = bodies_with_springs()
    other.add_ground_spring(0, "end", stiffness=(1.0, 0.0, 0.0))
    assert model_files._multibody_difference(system, other.build()) == "springs"


def test_coupling_springs_round_trip(tmp_path):
    mb = MultibodyBuilder()
    j = mb.add_body(flexible_body(length=0.5, n_elements=2, section=SEC), position=(0.25, 0.0, 0.0))
    mb.fix(j, "start")
    b = pf.ModelBuilder()
    n0 = b.add_node((0.5, 0.0, 0.0))
    n1 = b.add_line(n0, (1.0, 0.0, 0.0), 2, SEC)[-1]

    def coupled(extra=False):
        cs = CoupledSystem(b.build(floating=True), mb.build())
        cs.add_bushing(n0, j, "end", stiffness=(1e4, 1e4, 1e4), rotational_stiffness=(20.0, 30.0, 40.0),
                       damping=(0.0, 1.0, 0.0))
        cs.add_spring(n1, j, "start", stiffness=10.0, damping=0.3)
        if extra:
            cs.add_spring(n1, j, "center", stiffness=1.0)
        return cs

    cs = coupled()
    path = pf.save_model(cs, tmp_path / "c.yaml")
    text = path.read_text()
    assert "- bushing:" in text and "- axial:" in text
    again = pf.load_model(path)
    assert model_files._coupled_difference(cs, again) is None
    assert pf.save_model(again, tmp_path / "d.yaml").read_text() == text
    assert pf.static_equilibrium(again).state.q.tolist() == pf.static_equilibrium(cs).state.q.tolist()
    assert model_files._coupled_difference(cs, coupled(extra=True)) == "coupling springs"


def test_hand_written_spring_entries_are_checked(tmp_path):
    text = """pipeflex_model: 1
kind: multibody
sections:
  s: {EI: 50.0, EA: 1.0e4, GJ: 40.0, pipe_mass: 1.0}
bodies:
  b: {length: 0.5, n_elements: 2, section: s}
assembly:
  - {body: b, position: [0.25, 0.0, 0.0]}
joints:
  - fix: {body: 0, node: start}
springs:
  - bushing: {body_a: 0, node_a: end, body_b: 0, node_b: center, rotational_stiffnes: [1.0, 1.0, 1.0]}
"""
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(model_files.ModelFileError, match="rotational_stiffness"):
        pf.load_model(path)
    path.write_text(text.replace("rotational_stiffnes", "rotational_stiffness"))
    system = pf.load_model(path)
    assert system._description[0]["_springs"][0]["kind"] == "bushing"
