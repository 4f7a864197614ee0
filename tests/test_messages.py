"""Messages of bad input along the user's path: each names the parameter (or the file or
the command-line option), the rule and the remedy, never a bare error of numpy, zipfile,
json, pybind11 or the C++ allocator."""
import re

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import scenes
from pipeflex.multibody import MultibodyBuilder, flexible_body

from helpers import fluttering_cantilever


def _section():
    return pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0)


def test_shooting_steps_are_bounded_by_memory():
    m, st = fluttering_cantilever()
    with pytest.raises(ValueError, match=r"steps = 1000000000 steps per period .* GiB .* at most 2 GiB, "
                                         r"i\.e\. steps <= \d+ here") as err:
        pf.periodic_orbit(m, period=0.1, state=st, steps=10**9)
    assert "memory" in str(err.value)


def test_damaged_result_file_is_named(tmp_path):
    m, st = fluttering_cantilever()
    path = pf.simulate(m, 0.002, state=st, n_outputs=3, progress=False, step=1e-3).save(tmp_path / "run.npz")
    raw = path.read_bytes()
    cut = tmp_path / "cut.npz"
    cut.write_bytes(raw[:len(raw) // 2])  # a copy that stopped half way
    for cls in (pf.Result, pf.TransientResult):
        with pytest.raises(ValueError, match=re.escape(str(cut)) + ": not a pipeflex result file, or a damaged one"):
            cls.load(cut)
    text = tmp_path / "notes.npz"
    text.write_text("not an archive")
    with pytest.raises(ValueError, match=re.escape(str(text)) + ": not a pipeflex result file"):
        pf.TransientResult.load(text)


def test_garbled_result_description_is_named(tmp_path):
    path = tmp_path / "garbled.npz"
    np.savez(path, __result__=np.array("{not json"))
    with pytest.raises(ValueError, match=re.escape(str(path)) + ": not a pipeflex result file, or a damaged one"):
        pf.Result.load(path)


def test_foreign_archive_as_legacy_transient_result_is_named(tmp_path):
    """An .npz without the result entry is read as the earlier TransientResult format:
    missing or garbled entries name the file, not numpy's KeyError or json's error."""
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, a=np.arange(3))
    with pytest.raises(ValueError, match=re.escape(str(foreign)) + r": not a pipeflex result file.*missing entry"):
        pf.TransientResult.load(foreign)
    arrays = {k: np.zeros(2) for k in pf.TransientResult._ARRAYS}
    legacy = tmp_path / "legacy.npz"
    np.savez(legacy, **arrays, stats=np.array("{oops"), metadata=np.array("{}"))
    with pytest.raises(ValueError, match=re.escape(str(legacy)) + ": not a pipeflex result file, or a damaged one"):
        pf.TransientResult.load(legacy)


@pytest.mark.parametrize("option", ["--json", "--out"])
def test_cli_checks_its_outputs_before_the_run(tmp_path, capsys, monkeypatch, option):
    from pipeflex.cli import main
    from pipeflex.seeds import validate

    def never(*args, **kwargs):
        raise AssertionError("the validation ran before its outputs were checked")

    monkeypatch.setattr(validate, "run", never)
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    target = str(blocker / "v.json") if option == "--json" else str(blocker)
    argv = ["validate", "--only", "table1", option, target] + (["--no-figures"] if option == "--json" else [])
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith(f"pipeflex: error: {option} {target}: ") and "is a file, not a folder" in err
    assert "Traceback" not in err


def test_cli_refuses_a_folder_as_json_file(tmp_path, capsys, monkeypatch):
    from pipeflex.cli import main
    from pipeflex.seeds import validate

    monkeypatch.setattr(validate, "run", lambda *a, **k: pytest.fail("ran before the check"))
    with pytest.raises(SystemExit) as exit_info:
        main(["validate", "--only", "table1", "--json", str(tmp_path), "--no-figures"])
    assert exit_info.value.code == 2
    assert f"--json {tmp_path}: {tmp_path} is a folder" in capsys.readouterr().err


def test_dict_as_floating_frame_section_is_named():
    fields = dict(EI=10.0, pipe_mass=8.0, fluid_mass=2.0)
    with pytest.raises(TypeError,
                       match=r"section must be a pipeflex\.PipeSection, got dict .*PipeSection\(\*\*section\)"):
        flexible_body(length=1.0, n_elements=4, section=fields)
    with pytest.raises(TypeError, match=r"body must be a FlexibleBody, got dict.*flexible_body\("):
        MultibodyBuilder().add_body_between(fields, (0, 0, 0), (1, 0, 0))
    with pytest.raises(TypeError, match=r"section must be a pipeflex\.PipeSection, got dict"):
        b = pf.ModelBuilder()
        b.add_line(b.add_node((0, 0, 0)), (1, 0, 0), 2, fields)


def test_dict_as_section_of_the_floating_frame_scene_is_named():
    with pytest.raises(TypeError, match=r"section must be a pipeflex\.PipeSection, got dict"):
        scenes.ffrf_cantilever_pipe(n_bodies=2, section=dict(EI=10.0, pipe_mass=8.0, fluid_mass=2.0))


@pytest.mark.parametrize("value", [None, 1e-3])
def test_rotary_inertia_of_a_section_is_three_numbers(value):
    with pytest.raises(ValueError, match=r"rotary_inertia must be 3 numbers .*\[kg m\]"):
        pf.PipeSection(EI=1.0, pipe_mass=1.0, rotary_inertia=value)


def test_poisson_ratio_of_a_tube_is_checked_by_name():
    with pytest.raises(ValueError, match=r"Poisson's ratio nu = E / \(2 G\) - 1 = 9 .* must be in \(-1, 0\.5\]"):
        pf.PipeSection.tube(outer_diameter=0.05, inner_diameter=0.04, E=2e11, G=1e10, density=7800.0,
                            fluid_density=1000.0, fluid_bulk_modulus=2.2e9)
    # a valid wall is unchanged
    sec = pf.PipeSection.tube(outer_diameter=0.05, inner_diameter=0.04, E=2.1e11, G=8.1e10, density=7800.0,
                              fluid_density=1000.0, fluid_bulk_modulus=2.2e9)
    assert sec.EA > 0


@pytest.mark.parametrize("inertia", [(1.0, 2.0), None, np.eye(3), 5.0])
def test_point_mass_inertia_is_named_when_given(inertia):
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (1, 0, 0), 2, _section())
    with pytest.raises(ValueError, match=r"inertia must be 3 principal moments \(I_x, I_y, I_z\) \[kg m\^2\]"):
        b.add_point_mass(nodes[-1], 1.0, inertia)


@pytest.fixture(scope="module")
def rotating():
    return scenes.rotating_cantilever(n_elements=2)


@pytest.mark.parametrize("gamma, detail", [("fast", "got 'fast'"), ([], "empty"), ([1.0, -2.0], r"gamma\[1\] = -2")])
def test_rotating_gamma_is_named(rotating, gamma, detail):
    with pytest.raises(ValueError, match=r"gamma \(Omega / omega0 \[-\]\) must be a number >= 0 .*" + detail):
        pf.rotating_frequencies(rotating, gamma=gamma)


def test_steady_rotation_without_flow_says_so():
    sprinkler = scenes.sprinkler(EI=100.0, n_elements=2)
    with pytest.raises(ValueError, match="mass_flow = 0 kg/s: no flow, no rotation.*give mass_flow != 0"):
        pf.steady_rotation(sprinkler, mass_flow=0.0)


def test_shooting_without_polar_inertia_names_it():
    """The shooting integrates as simulate does: a model whose pipe sections lack the polar
    rotary inertia gets simulate's message (what is missing and how to give it), not the
    core's generic one."""
    m = pf.scenes.cantilever_pipe(n_elements=4)
    with pytest.raises(ValueError, match=r"polar rotary inertia rho I_p .* 0 in 4 of the 4 pipe elements"):
        pf.periodic_orbit(m, mass_flow=30.0, period=0.44)
