"""Stability map of the cantilevered pipe conveying fluid: the dimensionless critical flow
speed and flutter frequency against the mass ratio (Gregory & Paidoussis 1966;
Paidoussis, "Fluid-Structure Interactions", vol. 1, Section 3.5), with gravity along the
pipe if asked (Paidoussis 1970, the hanging and the standing cantilever).

The pipe is a uniform clamped-free line of 3D pipe elements (Euler-Bernoulli, plug flow,
no dissipation, practically inextensible), made dimensionless by its units: length
L = 1 m, bending stiffness EI = 1 N m^2 and mass per length M + m = 1 kg/m (fluid M,
pipe m). Then the dimensionless groups of the continuous theory are read off directly:

    beta = M / (M + m)                  mass ratio          = fluid_mass [kg/m]
    u = U L sqrt(M / EI)                flow speed          = mdot / sqrt(beta)   (mdot = M U [kg/s])
    omega_bar = omega L^2 sqrt((M + m) / EI)   frequency    = omega [rad/s]
    gamma = (M + m) g L^3 / EI          gravity             = g [m/s^2] along the pipe

gamma > 0: a hanging pipe (gravity from the clamp towards the free end, the pipe in
tension); gamma < 0: a standing one (in compression; it buckles under its own weight at
gamma = -7.837 without flow). Each point is one :func:`~pipeflex.critical_mass_flow` of
that model (its static equilibrium under gravity first), run through
:func:`pipeflex.sweep` on a process pool or a Dask cluster.
"""
from __future__ import annotations

import functools
from typing import Optional, Sequence, Union

import numpy as np

from .. import _checks
from .._progress import logger
from .critical import critical_mass_flow


def cantilever(mass_ratio: float, *, n_elements: int = 32, gravity: float = 0.0):
    """The dimensionless cantilever of the map (L = 1 m, EI = 1 N m^2, M + m = 1 kg/m).

    Args:
        mass_ratio: beta [-] = M / (M + m), in (0, 1).
        n_elements: elements along the pipe.
        gravity: gamma [-] = (M + m) g L^3 / EI along the pipe; > 0 hanging, < 0 standing.

    Returns:
        The :class:`~pipeflex.Model`: the pipe along x from the clamped node 0 at the origin
        to the free end at x = 1 m, gravity (gamma, 0, 0) m/s^2.
    """
    from ..model import ModelBuilder
    from ..sections import PipeSection

    beta = _mass_ratio(mass_ratio)
    b = ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    b.add_line(root, (1.0, 0.0, 0.0), _checks.positive_int("n_elements", n_elements),
               PipeSection(EI=1.0, pipe_mass=1.0 - beta, fluid_mass=beta))
    b.clamp(root)
    g = _checks.finite("gravity", gravity)
    if g != 0.0:
        b.set_gravity((g, 0.0, 0.0))
    return b.build()


def critical_point(mass_ratio: float, gravity: float = 0.0, *, n_elements: int = 32, tol: float = 1e-10) -> dict:
    """One point of the map (module level, so that worker processes can import it).

    Args:
        mass_ratio: beta [-] = M / (M + m), in (0, 1).
        gravity: gamma [-] = (M + m) g L^3 / EI along the pipe (> 0 hanging).
        n_elements: elements along the pipe.
        tol: relative tolerance on the critical flow [-] (:func:`~pipeflex.critical_mass_flow`).

    Returns:
        dict: ``u_cr`` [-] critical flow speed U L sqrt(M / EI); ``omega_cr`` [-] frequency
        omega L^2 sqrt((M + m) / EI) at the onset (0 for divergence); ``kind``
        ("flutter" or "divergence"); ``mass_flow`` [kg/s] of the dimensionless model;
        ``evaluations`` (eigen-analyses used).
    """
    beta = _mass_ratio(mass_ratio)
    r = critical_mass_flow(cantilever(beta, n_elements=n_elements, gravity=gravity), tol=tol)
    return {"u_cr": r.mass_flow / np.sqrt(beta), "omega_cr": r.frequency, "kind": r.kind,
            "mass_flow": r.mass_flow, "evaluations": r.evaluations}


def stability_map(mass_ratio: Sequence[float], *, gravity: Union[float, Sequence[float]] = 0.0,
                  n_elements: int = 32, tol: float = 1e-10, executor=None, client=None,
                  workers: Optional[int] = None, store=None, progress: Optional[bool] = None):
    """Critical flow speed and frequency of the cantilevered pipe against the mass ratio.

    Args:
        mass_ratio: (n,) beta [-] = M / (M + m), each in (0, 1), no repeats.
        gravity: gamma [-] = (M + m) g L^3 / EI along the pipe (> 0 hanging, < 0 standing),
            or a list of them: then the map is computed for each (a dimension ``gravity``).
        n_elements: elements along the pipe (the critical flow converges like
            n_elements^-4: ~1e-5 relative at 32 elements below beta = 0.9).
        tol: relative tolerance on the critical flow [-].
        executor, client, workers, store, progress: where and how the points run, as in
            :func:`pipeflex.sweep` (default: a local process pool; ``client=`` a Dask
            ``Client``; ``executor="serial"`` in this process).

    Returns:
        ``xarray.Dataset`` with the coordinate ``mass_ratio`` (and ``gravity`` if a list was
        given, the first dimension) and the variables of :func:`critical_point`: ``u_cr``
        [-], ``omega_cr`` [-], ``kind``, ``mass_flow`` [kg/s], ``evaluations`` (each with
        ``units`` where it has one, "1" for the dimensionless ones, and ``long_name``), and
        ``error`` ("" where the point succeeded; a failed point, e.g. a standing pipe
        that buckles under its weight, has NaN numbers). ``attrs``: ``n_elements`` and,
        for one gravity, ``gravity``.

    The map's jumps (Gregory & Paidoussis): the flutter boundary of each mode is S-shaped
    in (beta, u), so the lowest critical speed jumps where another mode becomes the
    critical one (without gravity at beta = 0.29, 0.69 and 0.92; docs/stability_map.md).
    """
    from ..sweeps import sweep

    betas = [_mass_ratio(b) for b in np.atleast_1d(np.asarray(mass_ratio, dtype=float))]
    n = _checks.positive_int("n_elements", n_elements)
    _checks.positive("tol", tol)
    run = dict(executor=executor, client=client, workers=workers, store=store, progress=progress)
    logger.info("stability_map: %d mass ratios x %d gravities, %d elements", len(betas), np.size(gravity), n)
    if np.ndim(gravity) == 0:
        g = _checks.finite("gravity", gravity)
        fn = functools.partial(critical_point, gravity=g, n_elements=n, tol=tol)
        ds = sweep(fn, mass_ratio=betas, **run)
        ds.attrs["gravity"] = g
    else:
        gs = [_checks.finite("gravity", g) for g in gravity]
        fn = functools.partial(critical_point, n_elements=n, tol=tol)
        ds = sweep(fn, gravity=gs, mass_ratio=betas, **run)
    ds.attrs["n_elements"] = n
    from ..results import field_info
    for name in ds.variables:  # the dimensionless groups: units and long names of the table FIELDS
        if name != "error":
            ds.variables[name].attrs.update(field_info("stability_map", name)[0])
    logger.info("stability_map: done, %s of %s points failed", ds.attrs.get("n_failed"), ds.attrs.get("n_points"))
    return ds


def _mass_ratio(value) -> float:
    beta = _checks.finite("mass_ratio", value)
    if not 0.0 < beta < 1.0:
        raise ValueError(f"mass_ratio must be in (0, 1), got {value!r}")
    return beta
