"""Command line: ``pipeflex validate [--json PATH] [--out DIR] [--only GROUP ...]``."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="pipeflex", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    val = sub.add_parser("validate", help="recompute the seeds' published numbers and compare")
    val.add_argument("--json", type=Path, help="also write the rows as JSON to this file")
    val.add_argument("--out", type=Path, default=Path("out"), help="directory for figures (default out/)")
    val.add_argument("--no-figures", action="store_true", help="skip the figures")
    val.add_argument("--only", nargs="+", metavar="GROUP", help="validation groups to run (default all)")
    args = parser.parse_args(argv)

    from . import validate

    rows = validate.run(args.only)
    print(validate.format_rows(rows))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps([r.as_dict() for r in rows], indent=2))
    if not args.no_figures:
        for p in validate.write_figures(args.out):
            print(f"figure: {p}")
    return 0 if all(r.passed for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
