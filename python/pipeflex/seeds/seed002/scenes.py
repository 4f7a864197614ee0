"""Seed 002 (Berzeri & Shabana): its rotating beams as models with the seed's values."""
from __future__ import annotations

import numpy as np

from ... import _checks
from ..._options import renamed
from ...model import Model, ModelBuilder
from ...sections import PipeSection


#: Seed 002, Table 1: the beams of its refs. 19 (eccentrically suspended) and 21.
SPIN_UP_BEAMS = {
    "ref19": dict(length=10.0, density=3.0e3, area=4.0e-4, second_moment=1.997e-7, E=7.0e10, hub_radius=1.0,
                  omega=6.0),
    "ref21": dict(length=8.0, density=2.767e3, area=7.299e-5, second_moment=8.214e-9, E=6.895e10, hub_radius=0.0,
                  omega=4.0),
}


@renamed(model="elastic")
def rotating_cantilever(*, n_elements: int = 10, formulation: str = "ancf", elastic: str = "A",
                        hub_radius_ratio: float = 0.0, tip_mass_ratio: float = 0.0,
                        slenderness: float = 216.22, length: float = 1.0, EI: float = 1.0,
                        mass_per_length: float = 1.0, omega: float = 0.0, spin_up_time: float = 0.0) -> Model:
    """Cantilever clamped to a rigid hub turning about global z (seed 002, Fig. 8; Tables 2-5).

    The beam runs along global x from (R, 0, 0) to (R + L, 0, 0), R = hub_radius_ratio L;
    the hub centre is the origin. ``model.info`` holds ``omega0`` = sqrt(EI / (m L^3))
    [rad/s] (eq. 64; m = rho A L the beam mass), the unit of the tables' frequencies and
    of gamma = Omega / omega0.

    Args:
        n_elements: number of equal elements.
        formulation: ``"ancf"`` (planar ANCF beam, seed 002) or ``"pipe"`` (the 3D
            beam element of seed 000 without fluid: in-plane and flapwise bending).
        elastic: ANCF elastic force model, ``"A"`` or ``"0"`` (ignored for ``"pipe"``), as
            :meth:`~pipeflex.ModelBuilder.add_ancf_beam`; ``model=`` is its deprecated name.
        hub_radius_ratio: R / L [-]. tip_mass_ratio: N = m_t / m [-] (eq. 66).
        slenderness: L sqrt(A / I) [-]; sets EA = slenderness^2 EI / L^2. The default
            216.22 is the value implied by Table 2's LONGIT-I frequency (seed 002 notes).
        length: L [m]. EI: bending stiffness (in-plane and flapwise) [N m^2].
        mass_per_length: rho A [kg/m].
        omega: Omega [rad/s] final hub rate for time integration; spin_up_time: T [s] of
            eq. 13 (0: constant rate). Linear rotating analyses take gamma instead.
    """
    if formulation not in ("ancf", "pipe"):
        raise ValueError(f"formulation must be 'ancf' or 'pipe', got {formulation!r}")
    L = _checks.magnitude("length", length, "m")
    EI = _checks.magnitude("EI", EI, "N m^2")
    rho_a = _checks.positive("mass_per_length", mass_per_length)
    s = _checks.positive("slenderness", slenderness)
    R = _checks.non_negative("hub_radius_ratio", hub_radius_ratio) * L
    N = _checks.non_negative("tip_mass_ratio", tip_mass_ratio)
    EA = s**2 * EI / L**2
    b = ModelBuilder()
    if formulation == "ancf":
        sec = PipeSection(EI=EI, EA=EA, pipe_mass=rho_a)
        nodes = b.add_ancf_beam((R, 0.0, 0.0), (R + L, 0.0, 0.0), n_elements, sec, elastic=elastic)
    else:
        # torsion: GJ = EI / 1.3 (thin tube), massless, hence condensed in eigen-analyses
        sec = PipeSection(EI=EI, EA=EA, pipe_mass=rho_a)
        n0 = b.add_node((R, 0.0, 0.0))
        nodes = b.add_line(n0, (R + L, 0.0, 0.0), n_elements, sec)
    b.rotating_hub(nodes[0], omega=omega, spin_up_time=spin_up_time)
    if N > 0:
        b.add_point_mass(nodes[-1], N * rho_a * L)
    m = b.build()
    m.info.update(omega0=float(np.sqrt(EI / (rho_a * L**4))), length=L, hub_radius=R, tip_mass_ratio=N,
                  tip_node=nodes[-1], beam_nodes=tuple(nodes), formulation=formulation, elastic=elastic)
    return m


@renamed(model="elastic")
def spin_up_beam(*, reference: str = "ref21", n_elements: int = 2, elastic: str = "A",
                 omega: float = None, spin_up_time: float = 15.0) -> Model:
    """A beam of seed 002's Table 1 on a hub that spins it up by eq. 13 (Figs. 2-7).

    Args:
        reference: ``"ref19"`` (L = 10 m, eccentricity 1 m, Omega = 6 rad/s) or
            ``"ref21"`` (L = 8 m, hub at the beam's end; Omega = 2, 4, 10, 40 rad/s).
        n_elements: ANCF elements. elastic: elastic force model ``"A"`` or ``"0"``
            (``model=`` is its deprecated name).
        omega: final rate Omega [rad/s] (default: the reference's, 6 or 4 rad/s).
        spin_up_time: T [s] (the seed's 15 s).
    """
    if reference not in SPIN_UP_BEAMS:
        raise ValueError(f"reference must be one of {sorted(SPIN_UP_BEAMS)}, got {reference!r}")
    p = SPIN_UP_BEAMS[reference]
    L, rho_a = p["length"], p["density"] * p["area"]
    EI, EA = p["E"] * p["second_moment"], p["E"] * p["area"]
    w = p["omega"] if omega is None else _checks.finite("omega", omega)
    return rotating_cantilever(n_elements=n_elements, elastic=elastic, hub_radius_ratio=p["hub_radius"] / L,
                               slenderness=L * np.sqrt(EA / EI), length=L, EI=EI, mass_per_length=rho_a,
                               omega=w, spin_up_time=spin_up_time)


# -- seed 004: floating frame of reference -----------------------------------------------
