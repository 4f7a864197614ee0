"""Seed 004 (floating frame of reference): its pipe systems as models with the seed's values."""
from __future__ import annotations

import dataclasses
from typing import Optional

import numpy as np

from ... import _checks
from ..._options import scene_mass_flow
from ...multibody import MultibodyBuilder, flexible_body
from ...sections import PipeSection, require_section
from ...time_functions import Sine


def _tube(*, outer_diameter, inner_diameter, E, G, density, fluid_density) -> PipeSection:
    """A tube with its polar rotary inertia rho_p I_p (the torsion of floating-frame bodies
    needs it: without it the twist is a massless coordinate), bending rotary inertia 0."""
    sec = PipeSection.tube(outer_diameter=outer_diameter, inner_diameter=inner_diameter, E=E, G=G,
                           density=density, fluid_density=fluid_density, rotary_inertia=True)
    return dataclasses.replace(sec, rotary_inertia=(sec.rotary_inertia[0], 0.0, 0.0))


def _ffrf_chain(bodies, placements, flow_factor=1.0):
    """Bodies placed at (position, rotation), each rigidly joined to the next (end to start)."""

    b = MultibodyBuilder()
    ids = [b.add_body(body, position=p, rotation=R, flow_factor=flow_factor) for body, (p, R) in zip(bodies, placements)]
    for k in range(len(ids) - 1):
        b.rigid(ids[k], "end", ids[k + 1], "start")
    return b, ids


def _elements_per_body(value) -> int:
    n = _checks.positive_int("elements_per_body", value)
    if n % 2:
        raise ValueError(f"elements_per_body must be even (the floating frame sits at the centre node), got {n}")
    return n


def ffrf_cantilever_pipe(*, n_bodies: int, elements_per_body: int = 20, internal_modes: int = 0,
                         reduction: str = "craig_bampton", mass_flow: Optional[float] = None,
                         flow_speed: Optional[float] = None, tip_force: float = 0.0, length: float = 1.0,
                         section: PipeSection = None, fluid_lever_arm: str = "reference"):
    """Straight cantilever pipe of seed 004, section 8.1, as a chain of floating-frame bodies.

    Along global x from the clamped origin; the free end carries ``tip_force`` [N] along
    global z. The pipe is seed 000's Table 2 cantilever (EI = 10 N m^2, 8 and 2 kg/m)
    with the axial and torsional stiffness of seed 004's tube (OD 61.97 mm, ID 50.46 mm,
    E = 24.64 MPa, G = 9.48 MPa: EA = 2.50e4 N, GJ = 7.69 N m^2, polar rotary inertia
    rho_p I_p = 6.4e-3 kg m; bending rotary inertia 0); seed 004's tube data give
    EI = 9.997 N m^2 and 7.999 / 2.000 kg/m, within 4e-4 of the rounded values.

    Args:
        n_bodies: bodies of equal length L / n_bodies, rigidly connected.
        elements_per_body: beam elements per body (even). internal_modes: Craig-Bampton
            fixed-interface modes per body (0: boundary modes only, 18 coordinates per body).
        reduction: ``"craig_bampton"`` or ``"full"``.
        mass_flow: mdot [kg/s] (default 0); or instead flow_speed: sdot [m/s] relative
            to the pipe, mdot = fluid_mass sdot (the seed's 15 m/s is 30 kg/s).
        tip_force: [N] along global z at the free end. length: L [m].
        section: replaces the default :class:`~pipeflex.PipeSection`.
        fluid_lever_arm: ``"reference"`` (default: seed 004's formulation, which its figures
            come from) or ``"deformed"`` (the bodies' default; with a tip force the chain
            then flutters as the element model): :func:`~pipeflex.multibody.flexible_body`.

    Returns a :class:`~pipeflex.multibody.MultibodySystem`; ``info["tip"]`` = (body, node).
    """

    nb = _checks.positive_int("n_bodies", n_bodies)
    L = _checks.magnitude("length", length, "m")
    if section is None:
        tube = _tube(outer_diameter=0.06197, inner_diameter=0.05046, E=24.64e6, G=9.48e6, density=7870.0,
                     fluid_density=1000.0)
        section = PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=tube.EA, GJ=tube.GJ,
                              rotary_inertia=tube.rotary_inertia)
    section = require_section(section)
    mdot = scene_mass_flow(mass_flow, flow_speed, section.fluid_mass)
    body = flexible_body(length=L / nb, n_elements=_elements_per_body(elements_per_body), section=section,
                         internal_modes=internal_modes, reduction=reduction, fluid_lever_arm=fluid_lever_arm)
    b, ids = _ffrf_chain([body] * nb, [(((k + 0.5) * L / nb, 0.0, 0.0), None) for k in range(nb)])
    b.fix(ids[0], "start")
    if tip_force:
        b.add_load(ids[-1], "end", force=(0.0, 0.0, _checks.finite("tip_force", tip_force)))
    system = b.build(mass_flow=mdot)
    system.info.update(tip=(ids[-1], body.n_elements), scene="seed 004, sec. 8.1")
    return system


def ffrf_curved_pipe(*, E: float, n_bodies: int = 8, elements_per_body: int = 20, internal_modes: int = 0,
                     mass_flow: Optional[float] = None, flow_speed: Optional[float] = None, radius: float = 0.5,
                     reduction: str = "craig_bampton"):
    """Semicircular pipe hinged at its inlet (seed 004, section 8.2; seed 000's sprinkler).

    The semicircle of radius R lies in the global x-z plane: it leaves the hinge at the
    origin along +z, has its centre at (R, 0, 0) and ends at (2R, 0, 0). The hinge turns
    about global y. Tube: OD 36.80 mm, ID 35.68 mm, 7870 kg/m^3, Young's modulus E [Pa],
    nu = 0.3; water (1000 kg/m^3) at ``flow_speed`` sdot [m/s] relative to the pipe
    (default 10 m/s, the seed's), or at the mass flow ``mass_flow`` mdot [kg/s] = mu_f sdot.
    Each body is straight with the arc preimposed (eta0) and made stress-free.

    Args:
        E: Young's modulus [Pa] (seed: 0.9585e9, 9.585e9, 95.85e9).
        n_bodies: bodies along the semicircle. elements_per_body: elements per body.
        internal_modes: Craig-Bampton internal modes per body.
        mass_flow: mdot [kg/s]; or instead flow_speed: sdot [m/s] (neither: 10 m/s).
        radius: R [m]. reduction: ``"craig_bampton"`` or ``"full"``.

    Returns a :class:`~pipeflex.multibody.MultibodySystem` whose mass flow is mu_f sdot.
    """

    E = _checks.positive("E", E)
    R = _checks.magnitude("radius", radius, "m")
    nb = _checks.positive_int("n_bodies", n_bodies)
    if nb < 2:
        raise ValueError(f"n_bodies must be >= 2 (a body spans less than 180 degrees of the semicircle), got {nb}")
    sec = _tube(outer_diameter=0.0368, inner_diameter=0.03568, E=E, G=E / 2.6, density=7870.0,
                fluid_density=1000.0)
    mdot = scene_mass_flow(mass_flow, flow_speed, sec.fluid_mass, default=sec.fluid_mass * 10.0)
    Lb = np.pi * R / nb
    body = flexible_body(length=Lb, n_elements=_elements_per_body(elements_per_body), section=sec, internal_modes=internal_modes,
                         reduction=reduction, curvature=1.0 / R, fluid_lever_arm="reference")  # the seed's formulation
    places = []
    for k in range(nb):
        th = (k + 0.5) * np.pi / nb
        pos = (R - R * np.cos(th), 0.0, R * np.sin(th))
        ex = np.array([np.sin(th), 0.0, np.cos(th)])   # tangent (flow direction)
        ey = np.array([np.cos(th), 0.0, -np.sin(th)])  # towards the centre
        places.append((pos, np.column_stack([ex, ey, np.cross(ex, ey)])))
    b, ids = _ffrf_chain([body] * nb, places)
    b.hinge(ids[0], "start", (0.0, 1.0, 0.0))
    system = b.build(mass_flow=mdot)
    system.info.update(E=E, base=(ids[0], 0), tip=(ids[-1], body.n_elements), scene="seed 004, sec. 8.2")
    return system


#: Seed 004, sec. 8.3: joint and pipe points [m] of the concrete printer. The seed's Fig. 11
#: is not in the text, so the geometry is ours: the arm OA stands vertical, AB-BC is a
#: horizontal link (rigid at B) and CD hangs vertically from C to the nozzle D, which the
#: roller keeps at its height. The pipe bends outward at E and F, so that OE = EB and
#: BF = FD have the seed's lengths.
PRINTER_POINTS = {
    "O": (0.0, 0.0, 0.0), "A": (0.0, 0.0, 0.15), "B": (0.30, 0.0, 0.15), "C": (0.45, 0.0, 0.15),
    "D": (0.45, 0.0, -0.25),
}


def _apex(p, q, side, leg):
    """The point at distance ``leg`` from both p and q, on ``side`` of the line pq."""
    p, q, side = (np.asarray(x, float) for x in (p, q, side))
    m, d = 0.5 * (p + q), q - p
    n = side - (side @ d) / (d @ d) * d
    return m + np.sqrt(leg**2 - (d @ d) / 4) * n / np.linalg.norm(n)


def concrete_printer(*, mass_flow: Optional[float] = None, flow_speed: Optional[float] = None,
                     gravity: float = 9.81, junction_forces: bool = True):
    """The concrete-printing robot of seed 004, section 8.3 (Figs. 11-12).

    Arm: four solid steel rods (diameter 4 cm, 7870 kg/m^3, E = 200 GPa, G = 77 GPa),
    OA (0.15 m, 4 elements), AB (0.30 m, 10), BC (0.15 m, 4), CD (0.40 m, 14); hinges at O
    (global z, driven by M_O = 353 t sin(8 pi t) N m), at A (axis normal to the plane of OA
    and AB, driven by M_A = -5000 cos(1.5 pi t) N m, a motor between OA and AB), at C
    (normal to BC, CD); AB and BC rigidly joined at B; a roller holds the height of the
    nozzle D. Pipe: PET tube (OD 4 cm, ID 3.5 cm, 1330 kg/m^3, E = 3.4 GPa, G = 1.2 GPa),
    bodies OE, EB (0.20 m), BF, FD (0.28 m), 4 elements each, rigidly joined, hinged
    about global z at O and attached at B and D with free orientation. Concrete
    (2400 kg/m^3) flows from O to the nozzle at ``flow_speed`` sdot [m/s] (the seed's 0, 3
    and 6 m/s), or give ``mass_flow`` mdot [kg/s] = mu_f sdot instead (one of the two). Gravity
    ``gravity`` [m/s^2] along -z. All bodies use Craig-Bampton boundary modes.
    ``junction_forces``: the concrete's momentum flux turning at the kinks E, B, F pushes
    the pipe (P = mu_f sdot^2 = 83 N at 6 m/s; see
    :meth:`~pipeflex.multibody.MultibodyBuilder.build`); ``False`` is the seed's formulation
    as printed, which has no such force.

    The geometry (:data:`PRINTER_POINTS`) is an assumption: the seed's Fig. 11 is not
    available. With CD vertical below C the arm is at a toggle: the moment at A lifts C
    and is carried by the tension of CD and the roller, so the arm keeps its shape and
    the drive at O swings it about z.

    Returns a :class:`~pipeflex.multibody.MultibodySystem`; ``info["nozzle"]`` = (body, node).
    """

    g = _checks.non_negative("gravity", gravity)
    rod = PipeSection.tube(outer_diameter=0.04, inner_diameter=0.0, E=200e9, G=77e9, density=7870.0,
                           rotary_inertia=True)
    rod = dataclasses.replace(rod, rotary_inertia=(rod.rotary_inertia[0], 0.0, 0.0))
    tube = _tube(outer_diameter=0.04, inner_diameter=0.035, E=3.4e9, G=1.2e9, density=1330.0, fluid_density=2400.0)
    mdot = scene_mass_flow(mass_flow, flow_speed, tube.fluid_mass, default=None)
    sdot = _checks.finite("flow_speed", flow_speed) if flow_speed is not None else mdot / tube.fluid_mass
    P = {k: np.array(v) for k, v in PRINTER_POINTS.items()}
    P["E"] = _apex(P["O"], P["B"], (-1.0, 0.0, 1.0), 0.20)
    P["F"] = _apex(P["B"], P["D"], (1.0, 0.0, 0.0), 0.28)
    b = MultibodyBuilder()
    arm = {}
    for name, n_el in (("OA", 4), ("AB", 10), ("BC", 4), ("CD", 14)):
        p, q = P[name[0]], P[name[1]]
        body = flexible_body(length=float(np.linalg.norm(q - p)), n_elements=n_el, section=rod)
        arm[name] = b.add_body_between(body, p, q, up=(0.0, 1.0, 0.0) if name == "OA" else None, flow_factor=0.0)
    pipe = {}
    for name in ("OE", "EB", "BF", "FD"):
        p, q = P[name[0]], P[name[1]]
        body = flexible_body(length=float(np.linalg.norm(q - p)), n_elements=4, section=tube,
                             fluid_lever_arm="reference")  # the seed's formulation
        pipe[name] = b.add_body_between(body, p, q, up=(0.0, 1.0, 0.0))
    z, y = (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)

    b.hinge(arm["OA"], "start", z, torque=Sine(omega=8 * np.pi, envelope=([0.0, 10.0], [0.0, 3530.0])))
    b.hinge(arm["AB"], "start", y, arm["OA"], "end", torque=Sine(omega=1.5 * np.pi, envelope=-5000.0,
                                                                  phase=np.pi / 2))
    b.rigid(arm["AB"], "end", arm["BC"], "start")
    b.hinge(arm["CD"], "start", y, arm["BC"], "end")
    b.roller(arm["CD"], "end", z)
    b.hinge(pipe["OE"], "start", z)
    for p, q in (("OE", "EB"), ("EB", "BF"), ("BF", "FD")):
        b.rigid(pipe[p], "end", pipe[q], "start")
    b.spherical(pipe["EB"], "end", arm["AB"], "end")
    b.spherical(pipe["FD"], "end", arm["CD"], "end")
    b.set_gravity((0.0, 0.0, -g))
    system = b.build(mass_flow=mdot, junction_forces=junction_forces)
    system.info.update(nozzle=(arm["CD"], 14), arm=arm, pipe=pipe, points=P, flow_speed=sdot,
                       scene="seed 004, sec. 8.3")
    return system
