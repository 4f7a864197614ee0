"""``python -m pipeflex ...``: the ``pipeflex`` command (pipeflex.cli), for an environment whose
scripts directory is not on PATH."""
import sys

from .cli import main

sys.exit(main())
