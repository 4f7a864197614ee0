"""Command line of pipeflex (``pipeflex --help``)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

DESCRIPTION = "pipeflex: flexible multibody dynamics of beams and fluid-conveying pipes."
VALIDATE_HELP = ("Recompute the seeds' published numbers, print them beside ours and draw the "
                 "figures. Exit status 0 when every checked number is within its tolerance, 1 otherwise.")


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


def main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)

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
