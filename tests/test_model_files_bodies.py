"""Model files of floating-frame systems and coupled systems (kind: multibody, kind: coupled),
time functions in files, and the seed-004 scenes shipped as files."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import model_files
from pipeflex.model_files import ModelFileError
from pipeflex.multibody import MultibodyBuilder, MultibodySystem, flexible_body

MODELS = Path(pf.__file__).parent / "seeds" / "models"


def assert_same_system(a, b):
    """The two systems' builder descriptions agree bit for bit, and so do their residual
    and tangent at the assembly configuration (the user's path: evaluate)."""
    if isinstance(a, MultibodySystem):
        assert model_files._multibody_difference(a, b) is None
        st = a.initial_state()
        st.v[:] = np.linspace(-1.0, 1.0, st.v.size)  # moving: the velocity terms count too
        fa = a.evaluate(st, mass_flow=a.mass_flow)
        fb = b.evaluate(st, mass_flow=b.mass_flow)
        for x, y in zip(fa, fb):
            np.testing.assert_array_equal(x, y)
    else:
        assert model_files._coupled_difference(a, b) is None
        assert a.joints == b.joints


def rich_system():
    """Every kind of entry: shared and distinct bodies (curved, full reduction, internal
    modes, modal damping, fluid lever arm), both placements, every joint kind, loads with
    each kind of time function, gravity, flow factors, junction forces off."""
    pipe = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=2.5e4, GJ=7.7, rotary_inertia=(6e-3, 0.0, 0.0))
    rod = pf.PipeSection(EI=50.0, pipe_mass=3.0, EA=1e5, GJ=40.0, rotary_inertia=(1e-3, 0.0, 0.0))
    straight = flexible_body(length=0.5, n_elements=4, section=pipe, internal_modes=2,
                             modal_damping=np.linspace(0.01, 0.05, 14), fluid_lever_arm="reference")
    curved = flexible_body(length=0.4, n_elements=4, section=pipe, curvature=1.5, modal_damping=0.05)
    full = flexible_body(length=0.3, n_elements=2, section=rod, reduction="full")
    b = MultibodyBuilder()
    j0 = b.add_body(straight, position=(0.25, 0.0, 0.0))
    j1 = b.add_body(straight, position=(0.75, 0.0, 0.0))
    j2 = b.add_body_between(full, (1.0, 0.0, 0.0), (1.0, 0.3 * 0.6, 0.3 * 0.8), up=(1.0, 2.0, 2.0), flow_factor=0.0)
    alone = MultibodyBuilder()  # where the curved body's start node lies from its frame
    alone.fix(alone.add_body(curved, position=(0.0, 0.0, 0.0)), "start")
    alone = alone.build()
    start = alone.node_position(alone.initial_state(), 0, "start")
    j3 = b.add_body(curved, position=-start, flow_factor=-1.0)  # its start at the origin
    b.fix(j0, "start")
    b.rigid(j0, "end", j1, "start")
    b.hinge(j2, "start", (0.1, 0.6, 0.9), j1, "end",
            torque=pf.Sine(omega=3.0, envelope=([0.0, 1.0, 2.0], [0.0, 2.0, 2.5]), phase=0.1, mean=0.3))
    b.roller(j2, "end", (0.1, -0.4, 1.5))  # this and the hinge axis: normalised twice, they change bits
    b.spherical(j3, 0, j0, "start")
    b.add_load(j1, "center", force=(1.0, ([0.0, 0.5], [0.0, -2.0]), pf.Pulse(start=0.1, duration=0.2)),
               moment=(0.0, pf.Pulse(start=0.0, duration=0.1, shape="rectangle", amplitude=3.0), 0.0))
    b.add_load(j3, "end", force=(0.0, 0.0, -1.0))
    b.set_gravity((0.0, -9.81, 0.0))
    system = b.build(mass_flow=3.5, junction_forces=False)
    system.info.update(scene="rich", tip=(j1, 4))
    return system


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_multibody_round_trip(tmp_path, suffix):
    system = rich_system()
    path = pf.save_model(system, tmp_path / f"bodies{suffix}")
    again = pf.load_model(path)
    assert isinstance(again, MultibodySystem)
    assert_same_system(system, again)
    assert again.info == {"scene": "rich", "tip": [1, 4]}
    # the file written from the loaded system is the same text
    assert pf.save_model(again, tmp_path / f"again{suffix}").read_text() == path.read_text()
    if suffix == ".yaml":
        text = path.read_text()
        for word in ("kind: multibody", "junction_forces: false", "pulse:", "sine:", "table:", "roller:",
                     "spherical:", "fix:", "axis: [0.1, 0.6, 0.9]", "direction: [0.1, -0.4, 1.5]"):
            assert word in text, word


def test_multibody_round_trip_same_motion(tmp_path):
    """The reloaded system moves the same: a short transient (loads with time functions,
    a driven hinge) agrees bit for bit (same code, same data)."""
    system = rich_system()
    again = pf.load_model(pf.save_model(system, tmp_path / "b.yaml"))
    runs = [pf.simulate(s, 0.02, step=1e-3, n_outputs=3) for s in (system, again)]
    np.testing.assert_array_equal(runs[0].bodies.r, runs[1].bodies.r)
    np.testing.assert_array_equal(runs[0].bodies.eta, runs[1].bodies.eta)
    assert np.abs(runs[0].bodies.eta[-1]).max() > 0  # the loads moved it


def test_coupled_round_trip(tmp_path):
    system, inlet, hub = pf.scenes.sprinkler_on_hub(n_elements=4)
    path = pf.save_model(system, tmp_path / "c.yaml")
    again = pf.load_model(path)
    assert isinstance(again, pf.CoupledSystem)
    assert_same_system(system, again)
    assert again.joints[0].node == inlet and again.joints[0].body == hub
    assert "kind: coupled" in path.read_text()
    assert pf.save_model(again, tmp_path / "d.yaml").read_text() == path.read_text()


def test_coupled_hinge_round_trip(tmp_path):
    """A hinge coupling keeps the axis as given (normalising it twice would change bits)."""
    sec = pf.PipeSection(EI=10.0, pipe_mass=1.0, EA=1e4, GJ=8.0, rotary_inertia=(1e-3, 0.0, 0.0))
    b = pf.ModelBuilder()
    b.add_line(b.add_node((0.0, 0.0, 0.0)), (1.0, 0.0, 0.0), 2, sec)
    arm = b.build(floating=True)
    mb = MultibodyBuilder()
    hub = mb.add_body_between(flexible_body(length=0.2, n_elements=2, section=sec), (-0.2, 0.0, 0.0),
                              (0.0, 0.0, 0.0))
    mb.fix(hub, "start")
    system = pf.CoupledSystem(arm, mb.build())
    # the first two change bits when normalised twice: the file keeps the axis as given
    axes = [(0.1, -0.4, 0.2), (0.1, 0.6, 0.8), (0.3, -1.7, 0.9)]
    for k, axis in enumerate(axes):
        system._joints.clear()
        system.hinge(0, hub, "end", axis)
        again = pf.load_model(pf.save_model(system, tmp_path / f"h{k}.json"))
        assert again.joints == system.joints and again.joints[0].given_axis == axis


SEEDS = {
    "ffrf_cantilever_pipe": lambda: pf.scenes.ffrf_cantilever_pipe(n_bodies=8),
    "ffrf_curved_pipe": lambda: pf.scenes.ffrf_curved_pipe(E=9.585e9),
    "concrete_printer": lambda: pf.scenes.concrete_printer(flow_speed=6.0),
    "sprinkler_on_hub": lambda: pf.scenes.sprinkler_on_hub()[0],
    "beam_on_free_hub": lambda: pf.scenes.beam_on_free_hub(hub_inertia=1.0)[0],
}


def test_every_seed_004_scene_has_a_file():
    """Each seed-004 scene of pf.scenes (multibody and coupled) ships as a file tested here."""
    seed004 = {name for name, target in pf.scenes._LAZY.items()
               if "seed004" in target and name[0].islower()}
    assert seed004 == set(SEEDS)
    kinds = {p.stem for p in MODELS.glob("*.yaml") if "\nkind: " in p.read_text()}
    assert kinds == set(SEEDS)


@pytest.mark.parametrize("name", sorted(SEEDS))
def test_seed_files_load_equal_to_their_scenes(name):
    assert_same_system(pf.load_model(MODELS / f"{name}.yaml"), SEEDS[name]())


def test_seed_file_critical_flow_equals_the_scene():
    """The user's path: the file's critical mass flow is the scene's."""
    a = pf.critical_mass_flow(pf.load_model(MODELS / "ffrf_cantilever_pipe.yaml"))
    b = pf.critical_mass_flow(SEEDS["ffrf_cantilever_pipe"]())
    # to round-off: repeated runs of the same scene differ by ~100 ulps (the eigen-solves' BLAS)
    assert abs(a.mass_flow - b.mass_flow) <= 1024 * np.spacing(b.mass_flow) and a.kind == b.kind


def test_element_load_time_functions_round_trip(tmp_path):
    """add_load(time_function=) with a number, a table, a Sine (table envelope) and a Pulse
    is file data; the reloaded model's transient is the same; callables stay refused."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 4, pf.PipeSection(EI=10.0, pipe_mass=1.0,
                                                              rotary_inertia=(1e-4, 0.0, 0.0)))
    b.clamp(n0)
    b.add_load(nodes[1], force=(0.0, 0.0, 1.0), time_function=0.5)
    b.add_load(nodes[2], force=(0.0, 1.0, 0.0), time_function=(np.array([0.0, 0.1]), np.array([0.0, 1.0])))
    b.add_load(nodes[3], force=(0.0, 0.0, 2.0), time_function=pf.Sine(omega=20.0, envelope=([0.0, 1.0], [0.0, 1.0])))
    b.add_load(nodes[-1], moment=(0.0, 1.0, 0.0), time_function=pf.Pulse(start=0.01, duration=0.02,
                                                                         shape="rectangle", amplitude=2.0))
    model = b.build()
    path = pf.save_model(model, tmp_path / "loads.yaml")
    text = path.read_text()
    for word in ("time_function: 0.5", "table:", "sine:", "pulse:", "shape: rectangle"):
        assert word in text, word
    again = pf.load_model(path)
    runs = [pf.simulate(m, 0.05, step=1e-3, n_outputs=3) for m in (model, again)]
    np.testing.assert_array_equal(runs[0].x, runs[1].x)
    assert np.abs(runs[0].x[-1] - runs[0].x[0]).max() > 0
    b.add_load_function(nodes[1], lambda t: (np.zeros(3), np.zeros(3)), name="gust")
    with pytest.raises(ValueError, match="load function .* Python callable"):
        pf.save_model(b.build(), tmp_path / "fn.yaml")


def test_save_refuses_a_custom_basis(tmp_path):
    sec = pf.PipeSection(EI=10.0, pipe_mass=1.0, EA=1e4, GJ=8.0, rotary_inertia=(1e-3, 0.0, 0.0))
    body = flexible_body(length=1.0, n_elements=2, section=sec)
    custom = flexible_body(length=1.0, n_elements=2, section=sec, basis=body.basis)
    b = MultibodyBuilder()
    b.fix(b.add_body(custom, position=(0.5, 0.0, 0.0)), "start")
    with pytest.raises(ValueError, match="body 0 has a custom basis"):
        pf.save_model(b.build(), tmp_path / "custom.yaml")
    assert not (tmp_path / "custom.yaml").exists()


BODIES = """\
pipeflex_model: 1
kind: multibody
sections:
  s: {EI: 10.0, pipe_mass: 1.0, EA: 1.0e4, GJ: 8.0, rotary_inertia: [1.0e-3, 0.0, 0.0]}
bodies:
  beam: {length: 1.0, n_elements: 4, section: s}
assembly:
  - {body: beam, start: [0, 0, 0], end: [1, 0, 0]}
joints:
  - fix: {body: 0, node: start}
loads:
  - {body: 0, node: end, force: [0, 0, {sine: {omega: 2.0}}]}
"""


def write(tmp_path, text, name="m.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_hand_written_multibody_file(tmp_path):
    """The documented schema by hand: a body placed by start and end, a sine load; the
    file's static tip deflection under a constant load is F L^3 / (3 EI)."""
    system = pf.load_model(write(tmp_path, BODIES))
    assert isinstance(system, MultibodySystem) and len(system.bodies) == 1
    static = pf.load_model(write(tmp_path, BODIES.replace("{sine: {omega: 2.0}}", "-0.01"), "static.yaml"))
    tip = static.node_position(pf.static_equilibrium(static).state, 0, "end")
    assert tip[2] == pytest.approx(-0.01 / (3 * 10.0), rel=1e-3)


@pytest.mark.parametrize("change, line, key, message", [
    (("kind: multibody", "kind: multibdy"), 2, "kind", "did you mean 'multibody'"),
    (("n_elements: 4", "n_elemnts: 4"), 6, "bodies.beam.n_elemnts", "did you mean 'n_elements'"),
    (("n_elements: 4", "n_elements: 3"), 6, "bodies.beam", "must be even"),
    (("{body: beam,", "{body: bean,"), 8, "assembly[0].body", r"unknown body 'bean' \(did you mean 'beam'\?\)"),
    (("start: [0, 0, 0], end", "position: [0, 0, 0], end"), 8, "assembly[0].position", "not both"),
    (("fix: {body: 0", "fixed: {body: 0"), 10, "joints[0].fixed", "did you mean 'fix'"),
    (("fix: {body: 0", "fix: {body: 3"), 10, "joints[0].fix", "bodies 0..0"),
    (("node: start}", "node: middle}"), 10, "joints[0].fix.node", "must be a node index or one of"),
    (("{sine: {omega: 2.0}}", "{sin: {omega: 2.0}}"), 12, "loads[0].force[2].sin", "did you mean 'sine'"),
    (("{sine: {omega: 2.0}}", "{sine: {omega: -2.0}}"), 12, "loads[0].force[2].sine.omega", "must be a number > 0"),
    (("{sine: {omega: 2.0}}", "{table: {times: [0, 0], values: [1, 2]}}"), 12, "loads[0].force[2]",
     "times must increase strictly"),
    (("force: [0, 0,", "force: [0,"), 12, "loads[0].force", "must be 3 time functions"),
])
def test_errors_name_file_line_and_key(tmp_path, change, line, key, message):
    path = write(tmp_path, BODIES.replace(*change))
    with pytest.raises(ModelFileError, match=message) as info:
        pf.load_model(path)
    assert (info.value.path, info.value.line, info.value.key) == (path, line, key)
    assert str(info.value).startswith(f"{path}, line {line}, {key}: ")


def test_element_time_function_errors(tmp_path):
    text = """\
sections:
  s: {EI: 1.0, pipe_mass: 1.0}
geometry:
  - node: [0, 0, 0]
  - line: {start: 0, end: [1, 0, 0], n_elements: 2, section: s}
supports:
  - clamp: 0
loads:
  - {node: 2, force: [0, 0, 1], time_function: {pulse: {start: 0.0, duraton: 0.1}}}
"""
    with pytest.raises(ModelFileError, match="did you mean 'duration'") as info:
        pf.load_model(write(tmp_path, text))
    assert (info.value.line, info.value.key) == (9, "loads[0].time_function.pulse.duraton")


def test_pipeflex_run_on_seed_files(tmp_path):
    """The command line runs the seed-004 files: a static equilibrium of the printer, the
    critical flow of the cantilever chain, a short run of the coupled sprinkler (ParaView
    files too)."""
    def run(name, *args):
        return subprocess.run([sys.executable, "-m", "pipeflex.cli", "run", str(MODELS / f"{name}.yaml"), *args,
                               "--out", str(tmp_path)], capture_output=True, text=True, timeout=600)

    out = run("concrete_printer", "--analysis", "static")
    assert out.returncode == 0, out.stderr
    assert "static equilibrium of" in out.stdout and (tmp_path / "concrete_printer_static.png").exists()
    out = run("ffrf_cantilever_pipe", "--analysis", "critical")
    assert out.returncode == 0, out.stderr
    m = pf.critical_mass_flow(SEEDS["ffrf_cantilever_pipe"]()).mass_flow
    assert f"{m:.6g} kg/s" in out.stdout
    out = run("sprinkler_on_hub", "--analysis", "simulate", "--t-end", "0.02", "--n-outputs", "3", "--vtk")
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "vtk" / "sprinkler_on_hub.pvd").exists()


def test_springs_on_bodies_and_couplings_are_saved(tmp_path):
    """Springs of bodies and of couplings have file keys (the round trips:
    tests/test_spring_model_files.py): saving them writes them."""
    import pipeflex as pf
    from pipeflex.coupled import CoupledSystem
    from pipeflex.multibody import MultibodyBuilder, flexible_body

    sec = pf.PipeSection(EI=50.0, EA=1e4, GJ=40.0, pipe_mass=1.0, rotary_inertia=(1e-3, 5e-4, 5e-4))
    mb = MultibodyBuilder()
    j = mb.add_body(flexible_body(length=0.5, n_elements=2, section=sec), position=(0.25, 0.0, 0.0))
    mb.fix(j, "start")
    mb.add_ground_spring(j, "end", stiffness=(1.0, 1.0, 1.0))
    assert "- ground:" in pf.save_model(mb.build(), tmp_path / "bodies.yaml").read_text()
    mb = MultibodyBuilder()
    j = mb.add_body(flexible_body(length=0.5, n_elements=2, section=sec), position=(0.25, 0.0, 0.0))
    mb.fix(j, "start")
    b = pf.ModelBuilder()
    n0 = b.add_node((0.5, 0.0, 0.0))
    n1 = b.add_line(n0, (1.0, 0.0, 0.0), 2, sec)[-1]
    cs = CoupledSystem(b.build(floating=True), mb.build())
    cs.rigid(n0, j, "end")
    cs.add_spring(n1, j, "start", stiffness=10.0)
    assert "- axial:" in pf.save_model(cs, tmp_path / "coupled.yaml").read_text()
