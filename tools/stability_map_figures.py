"""Regenerate docs/figures/stability_map.png and stability_map_gravity.png (docs/stability_map.md)
at full resolution: 393 mass ratios x 3 gravities, 32 elements, and the continuous beam's
determinant at 19 x 3 points.

Usage: .venv/bin/python tools/stability_map_figures.py

It executes notebooks/stability_map.ipynb in full mode in place (tools/run_notebooks.py: the
notebook keeps its outputs, so its stored run and the committed figures are one run); the
notebook saves its figures in notebooks/out/ (git-ignored), from where they are copied to
docs/figures/. About 10 minutes on 2 cores (the map's points run on a process pool, one
worker per core).
"""
import shutil
import sys
from pathlib import Path

TOOLS = Path(__file__).resolve().parent
REPO = TOOLS.parent
NOTEBOOK = REPO / "notebooks" / "stability_map.ipynb"
FIGURES = ("stability_map.png", "stability_map_gravity.png")

sys.path.insert(0, str(TOOLS))
import run_notebooks  # noqa: E402  (tools/ is not a package)


def main():
    run_notebooks.main([NOTEBOOK])
    for name in FIGURES:
        source = NOTEBOOK.parent / "out" / name
        shutil.copyfile(source, REPO / "docs" / "figures" / name)
        print("copied", source.relative_to(REPO), "-> docs/figures/" + name)


if __name__ == "__main__":
    main()
