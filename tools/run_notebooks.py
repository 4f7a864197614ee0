"""Execute notebooks in place (full mode) so that their outputs are stored.

Usage: .venv/bin/python tools/run_notebooks.py [notebooks/*.ipynb]
"""
import json
import os
import sys
import tempfile
from pathlib import Path

import nbformat
from nbclient import NotebookClient


def main(paths):
    with tempfile.TemporaryDirectory() as root:
        spec = Path(root) / "kernels" / "python3"
        spec.mkdir(parents=True)
        (spec / "kernel.json").write_text(json.dumps({
            "argv": [sys.executable, "-Xfrozen_modules=off", "-m", "ipykernel_launcher", "-f", "{connection_file}"],
            "display_name": "pipeflex venv", "language": "python"}))
        os.environ.update(JUPYTER_PATH=root, MPLBACKEND="module://matplotlib_inline.backend_inline")
        os.environ.pop("PIPEFLEX_FAST", None)
        for p in paths or sorted(Path("notebooks").glob("*.ipynb")):
            p = Path(p)
            nb = nbformat.read(p, as_version=4)
            NotebookClient(nb, timeout=3600, kernel_name="python3",
                           resources={"metadata": {"path": str(p.parent)}}).execute()
            # the kernel `make notebooks` registers, which the notebooks ask for by name
            nb.metadata["kernelspec"] = {"name": "pipeflex", "display_name": "Python (pipeflex)", "language": "python"}
            nbformat.write(nb, p)
            print("executed", p)


if __name__ == "__main__":
    main(sys.argv[1:])
