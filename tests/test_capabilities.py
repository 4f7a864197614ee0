"""The capability table of the user guide (docs/capabilities.md), generated here: each
analysis run on each formulation (an element model, floating-frame bodies, a coupled
system), on a small scene that the analysis fits. A "yes" is a run that returned its
result here; otherwise the cell is the error's first sentence, which must name the reason
(never a crash or a bare type error). The test fails when the table in the docs differs
from what the code does; regenerate it with PIPEFLEX_WRITE_CAPABILITIES=1."""
import os
import re
from pathlib import Path

import numpy as np
import pytest

import pipeflex as pf
from helpers import l_sprinkler, on_clamped_hub
from pipeflex.seeds.seed000.limit_cycle import limit_cycle_model
from pipeflex.seeds.seed004.coupled_scenes import sprinkler_on_hub

DOC = Path(__file__).resolve().parents[1] / "docs" / "capabilities.md"
FORMULATIONS = ("element model", "bodies", "coupled system")


def cantilever(kind):
    """A fluttering cantilever of each formulation (seed 000's Fig. 3 arm: 1 m, 30 kg/s)."""
    if kind == "element model":
        return limit_cycle_model(n_elements=4, tip_force=1.5, planar=True, EA=1e5)[0]
    if kind == "bodies":
        return pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.5, mass_flow=30.0)
    arm = pf.ModelBuilder()
    root = arm.add_node((0.0, 0.0, 0.0))
    nodes = arm.add_line(root, (1.0, 0.0, 0.0), 4, pf.PipeSection(EI=10.0, EA=1e5, GJ=10.0 / 1.3, pipe_mass=8.0,
                                                                     fluid_mass=2.0, rotary_inertia=(1e-4, 0, 0)))
    arm.add_load(nodes[-1], force=(0.0, 1.5, 0.0))
    arm.reservoir_inlet(root)  # fed from a still reservoir, as the clamped cantilever
    return on_clamped_hub(arm.build(mass_flow=30.0, floating=True), root, stiffness_ratio=1e4)


def sprinkler(kind):
    if kind == "element model":
        return pf.scenes.sprinkler(EI=100.0, n_elements=4, mass_flow=10.0)
    if kind == "bodies":
        return l_sprinkler(100.0, mass_flow=2.0)
    return sprinkler_on_hub(n_elements=4, mass_flow=10.0)[0]


def rotating(kind):
    """A beam on a hub turning at a prescribed rate (seed 002); bodies and coupled systems
    have no prescribed hub motion, so their cantilever stands in."""
    if kind == "element model":
        from pipeflex.seeds.seed002.scenes import rotating_cantilever
        return rotating_cantilever(n_elements=4)
    return cantilever(kind)


def run_static(kind):
    pf.static_equilibrium(cantilever(kind), mass_flow=1.0)


def run_arclength(kind):
    pf.static_equilibrium(cantilever(kind), mass_flow=1.0, path="arclength")


def run_flow_continuation(kind):
    pf.static_equilibrium(cantilever(kind), mass_flow=1.0, from_mass_flow=0.0, load_steps=2)


def run_linearize(kind):
    pf.linearize(cantilever(kind), mass_flow=1.0)


def run_stability(kind):
    pf.stability(pf.eigenvalues(pf.linearize(cantilever(kind), mass_flow=1.0)))


def run_critical(kind):
    pf.critical_mass_flow(cantilever(kind))


def run_steady(kind):
    pf.steady_rotation(sprinkler(kind))


def run_alpha(kind):
    pf.simulate(cantilever(kind), 0.01, step=1e-3, n_outputs=3, progress=False, integrator="generalized_alpha")


def run_ida(kind):
    pf.simulate(cantilever(kind), 0.01, n_outputs=3, progress=False, integrator="ida")


def run_orbit_guess(kind):
    # the cycle in the tip force's plane (the FFRF scene's force is along z)
    return pf.orbit_guess(cantilever(kind), node=4, step=2e-3, t_max=20.0, component=2 if kind == "bodies" else 1)


def run_periodic(kind):  # from a guess on its cycle
    g = run_orbit_guess(kind)
    pf.periodic_orbit(cantilever(kind), period=g.period, state=g.state, steps=int(round(g.period / 1e-3)))


def run_continue(kind):
    model = cantilever(kind)
    hopf = pf.critical_mass_flow(model)
    pf.continue_orbits(model, start=hopf, mass_flow_end=1.01 * hopf.mass_flow, steps=40, max_points=2)


def run_continue_gravity(kind):  # from an orbit of the mass-flow branch, in a gravity component by name
    model = cantilever(kind)
    hopf = pf.critical_mass_flow(model)
    br = pf.continue_orbits(model, start=hopf, mass_flow_end=1.01 * hopf.mass_flow, steps=40, max_points=1)
    orbit = pf.periodic_orbit(model, period=br.period[0], state=br.starts[0], mass_flow=br.mass_flow[0], steps=40)
    pf.continue_orbits(model, start=orbit, parameter="gravity_y", end=-0.01, ds=0.01, max_points=1)


def run_forced(kind):  # the model's own tip load driven harmonically, without flow
    pf.forced_response(cantilever(kind), load_factor=pf.Sine(omega=1.0, envelope=0.01), frequencies=(5.0, 6.0),
                       mass_flow=0.0, steps=32, max_points=2)


def run_backbone(kind):
    pf.backbone(cantilever(kind), node=4, component=1, amplitude_max=1e-3, n_points=1, steps=64)


def run_campbell(kind):
    pf.campbell(rotating(kind), gamma=[0.0, 1.0])


def run_rotating_frequencies(kind):
    pf.rotating_frequencies(rotating(kind), gamma=[1.0])


def run_parametric(kind):
    pf.parametric_stability(cantilever(kind), mean_flow=1.0, amplitude=0.1, frequency=20.0)


def run_model_file(kind, tmp=Path(os.environ.get("TMPDIR", "/tmp"))):
    import tempfile

    with tempfile.TemporaryDirectory(dir=tmp) as folder:
        pf.load_model(pf.save_model(cantilever(kind), Path(folder) / "m.yaml"))


ANALYSES = {
    "static_equilibrium (load steps)": run_static,
    "static_equilibrium (arc-length)": run_arclength,
    "static_equilibrium (flow continuation)": run_flow_continuation,
    "linearize": run_linearize,
    "eigenvalues, stability": run_stability,
    "critical_mass_flow": run_critical,
    "steady_rotation": run_steady,
    "simulate (generalised-α)": run_alpha,
    "simulate (IDA)": run_ida,
    "orbit_guess": run_orbit_guess,
    "periodic_orbit": run_periodic,
    "continue_orbits": run_continue,
    "continue_orbits (gravity by name)": run_continue_gravity,
    "forced_response": run_forced,
    "backbone": run_backbone,
    "campbell": run_campbell,
    "rotating_frequencies": run_rotating_frequencies,
    "parametric_stability, instability_chart": run_parametric,
    "save_model, load_model": run_model_file,
}


def cell(run, kind) -> str:
    try:
        run(kind)
    except (ValueError, TypeError, pf.ConvergenceError) as e:
        first = re.split(r"(?<=[a-z)])\. ", str(e).strip(), maxsplit=1)[0]
        # require_model's reason without its preamble and pointer back to this page
        first = re.sub(r" \(docs/capabilities.md[^)]*\)$", "", re.sub(r"^.*element models only: ", "", first))
        return f"no: {first}".replace("|", "/")
    return "yes"


def table() -> str:
    rows = ["| analysis | " + " | ".join(FORMULATIONS) + " |", "|---|" + "---|" * len(FORMULATIONS)]
    for name, run in ANALYSES.items():
        rows.append(f"| {name} | " + " | ".join(cell(run, kind) for kind in FORMULATIONS) + " |")
    return "\n".join(rows) + "\n"


def test_the_capability_table_is_what_the_code_does():
    got = table()
    for line in got.splitlines()[2:]:
        for c in line.strip("|").split("|")[1:]:
            c = c.strip()
            assert c == "yes" or (c.startswith("no: ") and len(c) > 20), f"an unexplained cell: {line}"
    doc = DOC.read_text()
    head, sep, rest = doc.partition("<!-- table: generated by tests/test_capabilities.py -->\n")
    assert sep, f"{DOC} lacks its table marker"
    current = rest.split("\n\n", 1)[0] + "\n"
    if os.environ.get("PIPEFLEX_WRITE_CAPABILITIES"):
        tail = rest.split("\n\n", 1)[1] if "\n\n" in rest else ""
        DOC.write_text(head + sep + got + ("\n" + tail if tail else ""))
        return
    assert current == got, f"docs/capabilities.md is stale (PIPEFLEX_WRITE_CAPABILITIES=1 regenerates it):\n{got}"


@pytest.mark.parametrize("kind", FORMULATIONS)
def test_every_formulation_has_the_core_analyses(kind):
    """What the one system object gives every formulation: statics, linearisation,
    stability and generalised-alpha."""
    for name in ("static_equilibrium (load steps)", "linearize", "eigenvalues, stability",
                 "simulate (generalised-α)"):
        assert cell(ANALYSES[name], kind) == "yes", name
    np.testing.assert_equal(len(FORMULATIONS), 3)
