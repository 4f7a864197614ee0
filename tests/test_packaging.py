"""The user's path from a wheel: built from this checkout, installed into a fresh venv, used
from a folder of the user's (no PYTHONPATH, not the checkout).

The wheel is built without build isolation (``setup.py`` reuses the CMake build in
``build/cmake-pyXY``, so an up-to-date core is not compiled again); the venv sees the
system's site packages (numpy, scipy, matplotlib) but not this checkout's venv, where the
editable pipeflex lives. Skipped only when a wheel cannot be built here at all (no pip,
setuptools, wheel, pybind11 or CMake); a failing build fails.
"""
import email.parser
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import tarfile
import textwrap
import zipfile
from pathlib import Path

import pytest

import pipeflex

ROOT = Path(pipeflex.__file__).resolve().parents[2]
SOURCE = ROOT / "python" / "pipeflex"
# Meijaard & Hakvoort (seed 000), Table 2: critical mass flow [kg/s] of the cantilever pipe
# (L = 1 m, EI = 10 N m^2, 8 kg/m, 2 kg/m) with 4 elements, 8 significant digits printed
TABLE2_4_ELEMENTS = 25.054732
TOL_TABLE2 = 2e-7  # relative: the seed's validation tolerance (pipeflex.seeds.seed000.validation)
EXTRAS = {"sweeps", "dask", "notebooks", "docs", "files", "test", "all"}

SMOKE = textwrap.dedent("""
    import json
    import pipeflex as pf
    from pipeflex.seeds.seed000 import references, validation

    result = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=4))
    print(json.dumps({"file": pf.__file__, "core": pf._core.__file__, "mass_flow": result.mass_flow,
                      "kind": result.kind, "reference": references.TABLE2[4], "tol": validation.TOL_TABLE2}))
    """)


def _missing_build_tools():
    missing = [m for m in ("pip", "setuptools", "wheel", "pybind11", "venv") if importlib.util.find_spec(m) is None]
    return missing + ([] if shutil.which("cmake") else ["cmake"])


def _run(args, **kwargs):
    out = subprocess.run(args, capture_output=True, text=True, **kwargs)
    assert out.returncode == 0, f"{' '.join(map(str, args))} failed ({out.returncode}):\n{out.stdout[-3000:]}\n" \
                                f"{out.stderr[-3000:]}"
    return out.stdout


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    missing = _missing_build_tools()
    if missing:
        pytest.skip(f"a wheel cannot be built here: {', '.join(missing)} not available")
    out = tmp_path_factory.mktemp("wheel")
    _run([sys.executable, "-m", "pip", "wheel", "--no-build-isolation", "--no-deps", "-q", "-w", str(out), str(ROOT)])
    wheels = sorted(out.glob("pipeflex-*.whl"))
    assert len(wheels) == 1, f"expected one pipeflex wheel, found {wheels}"
    return wheels[0]


@pytest.fixture(scope="module")
def venv(wheel, tmp_path_factory):
    """A fresh venv from the base interpreter with the system's site packages and the wheel."""
    where = tmp_path_factory.mktemp("venv") / "env"
    base = getattr(sys, "_base_executable", sys.executable)
    # without pip of its own: the system's pip (a system site package) installs into it
    _run([base, "-m", "venv", "--system-site-packages", "--without-pip", str(where)])
    python = where / "bin" / "python"
    _run([str(python), "-m", "pip", "install", "--no-deps", "--no-index", "-q", str(wheel)], env=_user_env())
    return where


def _user_env():
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env["PYTHONNOUSERSITE"] = "1"  # ~/.local must not supply a pipeflex either
    env["MPLBACKEND"] = "Agg"
    return env


def test_wheel_ships_the_core_every_module_py_typed_and_declares_the_extras(wheel):
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        metadata_name = next(n for n in names if n.endswith(".dist-info/METADATA"))
        metadata = email.parser.Parser().parsestr(z.read(metadata_name).decode())
    assert "pipeflex/py.typed" in names
    assert any(n.startswith("pipeflex/_core") and n.endswith(".so") for n in names)
    sources = {f"pipeflex/{p.relative_to(SOURCE).as_posix()}" for p in SOURCE.rglob("*.py")
               if "__pycache__" not in p.parts}
    assert sorted(sources - names) == [], "modules missing from the wheel"
    assert not [n for n in names if n.startswith(("tests/", "build/", "notebooks/"))]

    assert set(metadata.get_all("Provides-Extra")) == EXTRAS
    requires = [_requirement(r) for r in metadata.get_all("Requires-Dist")]

    def extra(name):
        return {req for req, where in requires if where == name}

    assert extra(None) == {"numpy", "scipy", "matplotlib", "threadpoolctl"}
    assert {"xarray", "tqdm", "netcdf4"} <= extra("sweeps")
    assert {"pipeflex[sweeps]", "dask", "distributed"} <= extra("dask")
    assert {"pipeflex[dask]", "notebook", "ipykernel"} <= extra("notebooks")
    assert {"sphinx", "myst-parser"} <= extra("docs")
    assert {"pipeflex[dask,files]", "pytest", "pytest-timeout", "hypothesis", "nbclient", "nbformat"} <= extra("test")
    assert {"pyyaml", "meshio"} <= extra("files")
    assert extra("all") == {"pipeflex[dask,docs,files,notebooks,test]"}


def _requirement(line):
    """("name[extras]" in lower case, its extra or None) of a Requires-Dist line, e.g.
    'xarray>=2022.6; extra == "sweeps"' or 'numpy (>=1.21)' (older setuptools)."""
    spec, _, marker = line.partition(";")
    match = re.match(r"\s*([A-Za-z0-9._-]+)\s*(\[[^\]]*\])?", spec)
    extras = sorted(e.strip() for e in match.group(2).strip("[]").split(",")) if match.group(2) else []
    name = match.group(1).lower() + (f"[{','.join(extras)}]" if extras else "")
    where = re.search(r"extra\s*==\s*['\"]([^'\"]+)['\"]", marker)
    return name, where.group(1) if where else None


def test_installed_wheel_runs_a_study_and_the_command_line_outside_the_checkout(venv, tmp_path):
    python, env = venv / "bin" / "python", _user_env()
    out = json.loads(_run([str(python), "-c", SMOKE], cwd=tmp_path, env=env).splitlines()[-1])
    for key in ("file", "core"):  # the wheel's copy, not the checkout's
        path = Path(out[key]).resolve()
        assert path.is_relative_to(venv.resolve()), f"pipeflex {key} {path} is not inside the new venv {venv}"
        assert not path.is_relative_to(ROOT), f"pipeflex {key} {path} comes from the checkout"
    assert out["kind"] == "flutter"
    assert out["reference"] == TABLE2_4_ELEMENTS and out["tol"] == TOL_TABLE2
    assert out["mass_flow"] == pytest.approx(TABLE2_4_ELEMENTS, rel=TOL_TABLE2)

    script = venv / "bin" / "pipeflex"
    assert script.exists(), "the wheel installed no `pipeflex` command"
    text = _run([str(script), "--help"], cwd=tmp_path, env=env)
    assert "usage: pipeflex" in text and "validate" in text
    groups = _run([str(script), "validate", "--list"], cwd=tmp_path, env=env)
    assert groups.strip(), "`pipeflex validate --list` printed no validation groups"


def test_sdist_carries_the_cpp_core_that_setup_py_builds(tmp_path):
    """``pip install pipeflex-*.tar.gz`` builds the core with CMake: the sdist needs it (MANIFEST.in)."""
    if importlib.util.find_spec("setuptools") is None:
        pytest.skip("an sdist cannot be built here: setuptools not available")
    code = f"import setuptools.build_meta as b; print(b.build_sdist({str(tmp_path)!r}))"
    name = _run([sys.executable, "-c", code], cwd=ROOT).splitlines()[-1]
    with tarfile.open(tmp_path / name) as tar:
        members = {m.split("/", 1)[1] for m in tar.getnames() if "/" in m}
    needed = {"CMakeLists.txt", "setup.py", "pyproject.toml", "python/pipeflex/py.typed"}
    needed |= {p.relative_to(ROOT).as_posix() for p in (ROOT / "cpp").rglob("*") if p.is_file()}
    assert sorted(needed - members) == []
