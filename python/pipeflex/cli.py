"""Command line of pipeflex (``pipeflex --help``)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

DESCRIPTION = "pipeflex: flexible multibody dynamics of beams and fluid-conveying pipes."
VALIDATE_HELP = ("Recompute the seeds' published numbers, print them beside ours and draw the "
                 "figures. Exit status 0 when every checked number is within its tolerance, 1 otherwise.")


RUN_HELP = ("Load a model file (docs/model_files.md: an element model, a system of floating-frame bodies or a "
            "coupled system) and run an analysis: write its result (.npz; netCDF .nc for a time integration when "
            "xarray and netCDF4 are installed) and a figure into --out.")
ANALYSES = ("static", "critical", "simulate")


def _parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = argparse.ArgumentParser(prog="pipeflex", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"pipeflex {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    val = sub.add_parser("validate", help="recompute the seeds' published numbers and compare",
                         description=VALIDATE_HELP)
    val.add_argument("--list", action="store_true", help="list the validation groups and exit")
    val.add_argument("--only", nargs="+", metavar="GROUP",
                     help="run only these groups, figures included (default: all; see --list)")
    val.add_argument("--json", type=Path, metavar="PATH", help="also write the rows as JSON to this file")
    val.add_argument("--out", type=Path, default=Path("out"), metavar="DIR",
                     help="folder for the figures (default: out)")
    val.add_argument("--no-figures", action="store_true", help="skip the figures")
    run = sub.add_parser("run", help="load a model file and run an analysis on it", description=RUN_HELP)
    run.add_argument("model", type=Path, help="the model file (.yaml, .yml or .json; docs/model_files.md)")
    run.add_argument("--analysis", choices=ANALYSES, default="static",
                     help="static: equilibrium; critical: critical mass flow; simulate: time integration "
                          "(default: static)")
    run.add_argument("--t-end", type=float, metavar="SECONDS", help="end time [s] of --analysis simulate")
    run.add_argument("--n-outputs", type=int, default=201, metavar="N",
                     help="output times of --analysis simulate (default: 201)")
    run.add_argument("--out", type=Path, default=Path("out"), metavar="DIR",
                     help="folder for the results and the figure (default: out)")
    run.add_argument("--vtk", action="store_true", help="also write ParaView files (DIR/vtk/<model>.pvd)")
    return parser


def _folder_problem(folder: Path):
    """None if ``folder`` exists or can be made and takes a new file, else why not. The
    folder is made if missing (the run would make it)."""
    import tempfile

    try:
        if folder.exists() and not folder.is_dir():
            return f"{folder} is a file, not a folder"
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        return f"cannot write in the folder {folder} ({exc.strerror or exc})"
    return None


def _output_problem(path: Path, option: str, *, folder: bool):
    """None if the run can write its output ``path`` (a folder, or a file whose folder is
    made if missing; an existing file is left as it is), else a message naming ``option``."""
    if folder:
        why = _folder_problem(path)
    elif path.is_dir():
        why = f"{path} is a folder; give a file path, e.g. {path / 'validation.json'}"
    else:
        why = _folder_problem(path.parent)
        if why is None and path.exists():
            try:
                with open(path, "r+b"):  # opened for writing, not truncated
                    pass
            except OSError as exc:
                why = f"cannot write the file {path} ({exc.strerror or exc})"
    return None if why is None else f"{option} {path}: {why} (checked before the run; give a writable path)"


def _run(parser, args) -> int:
    """``pipeflex run``: the analysis of a model file, its result and a figure in ``args.out``."""
    from .model_files import ModelFileError, load_model

    if args.analysis == "simulate":
        if args.t_end is None:
            parser.error("--analysis simulate needs --t-end SECONDS (the end time [s])")
        if not args.t_end > 0:
            parser.error(f"--t-end must be > 0 s, got {args.t_end:g}")
        if args.n_outputs < 2:
            parser.error(f"--n-outputs must be >= 2, got {args.n_outputs}")
    elif args.t_end is not None:
        parser.error(f"--t-end is for --analysis simulate, not {args.analysis}")
    try:
        model = load_model(args.model)
    except (ModelFileError, OSError, ValueError) as exc:
        parser.error(str(exc))
    problem = _output_problem(args.out, "--out", folder=True)  # after the model: a bad file makes no folder
    if problem:
        parser.error(problem)
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg", "cairo"):
        matplotlib.use("Agg")  # files only: no window
    import matplotlib.pyplot as plt

    from . import analysis, plot
    from .errors import ConvergenceError

    from .model import Model

    stem = args.model.stem
    # the parts of what the file holds: an element model, bodies, or both (a coupled system)
    elements = model if isinstance(model, Model) else getattr(model, "model", None)
    bodies = None if isinstance(model, Model) else (model if elements is None else model.bodies)
    fig = plt.figure(figsize=(6.4, 4.8))
    try:
        if args.analysis == "static":
            result = analysis.static_equilibrium(model)
            print(f"static equilibrium of {args.model}: {result.iterations} Newton iterations, residual "
                  f"{result.residual:.3g} N")
            ax = fig.add_subplot(projection="3d")
            if elements is not None:
                plot.model(elements, ax=ax, color="0.7", show_loads=False, show_flow=False, legend=False,
                           label="reference")
                plot.model(elements, result.state, ax=ax, label="equilibrium")
            if bodies is not None:
                _draw_bodies(ax, bodies, bodies.initial_state(), color="0.7")
                _draw_bodies(ax, bodies, result.state if elements is None else result.body_state, color="C0")
            ax.set_title(f"{stem}: static equilibrium")
        elif args.analysis == "critical":
            result = analysis.critical_mass_flow(model)
            print(f"critical mass flow of {args.model}: {result.mass_flow:.6g} kg/s ({result.kind}, "
                  f"frequency {result.frequency:.6g} rad/s)")
            ax = fig.add_subplot(projection="3d")
            if bodies is None:
                plot.mode_shape(model, result.mode, ax=ax)
            else:  # the mode of bodies has no drawing yet: the assembly
                if elements is not None:
                    plot.model(elements, ax=ax, legend=False)
                _draw_bodies(ax, bodies, bodies.initial_state(), color="C0")
            ax.set_title(f"{stem}: critical mode, mdot = {result.mass_flow:.4g} kg/s ({result.kind})")
        else:
            result = analysis.simulate(model, args.t_end, n_outputs=args.n_outputs)
            names, x = _node_paths(result)
            d = np.linalg.norm(x - x[:1], axis=2)  # (nt, n_nodes) [m]
            node = int(np.argmax(d.max(axis=0)))
            print(f"simulated {args.model} to t = {args.t_end:g} s: {len(result.t)} outputs, largest displacement "
                  f"{d[:, node].max():.4g} m at {names[node]}")
            ax = fig.add_subplot()
            plot.time_history(result.t, [x[:, node, i] - x[0, node, i] for i in range(3)],
                              quantity=f"displacement of {names[node]}", unit="m", labels=["x", "y", "z"], ax=ax,
                              title=f"{stem}: time integration")
    except (ValueError, ConvergenceError) as exc:  # the model's, not the command line's: status 1
        plt.close(fig)
        print(f"pipeflex run: {args.analysis} of {args.model} failed: {exc}", file=sys.stderr)
        return 1
    files = [_save_result(result, args.out / f"{stem}_{args.analysis}")]
    figure = args.out / f"{stem}_{args.analysis}.png"
    fig.savefig(figure, dpi=120)
    plt.close(fig)
    files.append(figure)
    if args.vtk and args.analysis != "critical":
        if args.analysis == "static" and elements is None:
            print("no ParaView files: a static result of bodies alone has no VTK export yet")
        else:
            files += result.to_vtk(args.out / "vtk", model, name=stem)
    for f in files:
        print(f"wrote {f}")
    return 0


def _draw_bodies(ax, bodies, state, *, color) -> None:
    """The floating-frame bodies' centre lines (through their nodes) at ``state``."""
    for x in bodies.centre_line(state):
        ax.plot(x[:, 0], x[:, 1], x[:, 2], color=color, marker=".", markersize=3)


def _node_paths(result):
    """(names, (n_out, n, 3) positions [m]) of every node of a transient: element nodes,
    then each body's nodes."""
    names, parts = [], []
    if result.x is not None:
        names += [f"node {n}" for n in range(result.x.shape[1])]
        parts.append(np.asarray(result.x))
    if result.bodies is not None:
        for j, s in enumerate(result.bodies.nodes_s):
            names += [f"body {j} node {i}" for i in range(len(s))]
            parts.append(np.stack([result.bodies.node_position(j, i) for i in range(len(s))], axis=1))
    return names, np.concatenate(parts, axis=1)


def _save_result(result, stem: Path) -> Path:
    """The result as netCDF (``stem.nc``) where it has ``to_xarray`` (element nodes) and
    netCDF4 is there, else as .npz (:meth:`pipeflex.Result.save`)."""
    if hasattr(result, "to_xarray"):
        try:
            import netCDF4  # noqa: F401 (xarray's netCDF engine)
            import xarray  # noqa: F401
        except ImportError:
            pass
        else:
            try:
                data = result.to_xarray()
            except ValueError:  # a run of bodies alone: no element nodes to hold
                data = None
            if data is not None:
                path = stem.with_suffix(".nc")
                data.to_netcdf(path)
                return path
    return result.save(stem.with_suffix(".npz"))


def main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command == "run":
        return _run(parser, args)

    from .seeds import validate

    if args.list:
        width = max(map(len, validate.GROUPS))
        for name, group in validate.GROUPS.items():
            print(f"{name:{width}s}  {group.description}")
        return 0
    if args.only:
        unknown = [g for g in args.only if g not in validate.GROUPS]
        if unknown:
            parser.error(f"unknown validation group {', '.join(unknown)} (pipeflex validate --list shows them)")
    # the run takes minutes: refuse an output it could not write before it, not after
    problem = _output_problem(args.json, "--json", folder=False) if args.json else None
    if problem is None and not args.no_figures:
        problem = _output_problem(args.out, "--out", folder=True)
    if problem:
        parser.error(problem)
    rows = validate.run(args.only)
    print(validate.format_rows(rows))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps([r.as_dict() for r in rows], indent=2))
    if not args.no_figures:
        for p in validate.write_figures(args.out, args.only):
            print(f"figure: {p}")
    return 0 if all(r.passed for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
