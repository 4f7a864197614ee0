"""Parameter studies: a function over a grid of parameter values, run in parallel (local
processes, any ``concurrent.futures`` executor, or a Dask cluster), with the results as an
``xarray.Dataset`` and a store that lets an interrupted sweep resume. See docs/sweeps.md.

``pipeflex.sweep`` is :func:`~pipeflex.sweeps.run.sweep`; xarray and Dask load when a
sweep runs (tqdm only when it draws a progress bar), not with ``import pipeflex``.
"""
from .outcome import limit_blas_threads
from .run import SERIAL, SweepIncomplete, sweep

__all__ = ["sweep", "SweepIncomplete", "limit_blas_threads", "SERIAL"]
