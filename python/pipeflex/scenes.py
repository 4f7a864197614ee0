"""The seeds' test problems as ready-made models (defaults are the seeds' values)."""
from __future__ import annotations

import dataclasses

import numpy as np

from . import _checks
from .model import Model, ModelBuilder
from .sections import PipeSection


def simply_supported_pipe(*, n_elements: int, length: float = 1.0, EI: float = 1.0,
                          pipe_mass: float = 0.75, fluid_mass: float = 0.25, kv: float = 1.0,
                          mass_flow: float = 0.0) -> Model:
    """Straight pipe simply supported at both ends, axially supported at the inlet
    (seed 000, section 3.1, Fig. 1; Table 1).

    Along global x from the origin; both bending planes (xy, xz) are modelled. The inlet
    node is pinned and its torsion fixed; the outlet node is held laterally (y, z) and
    free to slide along x. The static buckling flow is mdot = (pi/L) sqrt(rho_f A_f EI / k_v).

    Args:
        n_elements: number of equal elements.
        length: L [m]. EI: bending stiffness [N m^2]. pipe_mass: rho_p A_p [kg/m].
        fluid_mass: rho_f A_f [kg/m]. kv: momentum-flux factor [-]. mass_flow: mdot [kg/s].
    """
    L = _checks.positive("length", length)
    sec = PipeSection(EI=EI, pipe_mass=pipe_mass, fluid_mass=fluid_mass, kv=kv, EA=1e10 * EI / L**2)
    b = ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (L, 0.0, 0.0), n_elements, sec)
    b.fix(nodes[0], ("ux", "uy", "uz", "rx"))
    b.fix(nodes[-1], ("uy", "uz"))
    return b.build(mass_flow=mass_flow)


def cantilever_pipe(*, n_elements: int, length: float = 1.0, EI: float = 10.0, pipe_mass: float = 8.0,
                    fluid_mass: float = 2.0, kv: float = 1.0, mass_flow: float = 0.0,
                    polar_inertia: float = 0.0) -> Model:
    """Straight cantilever pipe clamped at the inlet, free jet at the outlet
    (seed 000, section 3.2, Fig. 2; Table 2). Along global x from the origin.

    Args:
        n_elements: number of equal elements.
        length: L [m]. EI: bending stiffness [N m^2]. pipe_mass: rho_p A_p [kg/m].
        fluid_mass: rho_f A_f [kg/m]. kv: momentum-flux factor [-]. mass_flow: mdot [kg/s].
        polar_inertia: rho I_p [kg m] rotary inertia per length about the pipe axis (0, as
            in the seed's tables). Time integration needs it > 0 (a regular mass matrix);
            it does not enter the bending motion.
    """
    L = _checks.positive("length", length)
    sec = PipeSection(EI=EI, pipe_mass=pipe_mass, fluid_mass=fluid_mass, kv=kv, EA=1e10 * EI / L**2,
                      rotary_inertia=(_checks.non_negative("polar_inertia", polar_inertia), 0.0, 0.0))
    b = ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (L, 0.0, 0.0), n_elements, sec)
    b.clamp(n0)
    return b.build(mass_flow=mass_flow)


#: Bending stiffness [N m^2] standing in for a rigid sprinkler pipe (10^6 x the stiffest
#: flexible case): its steady speed then differs from the rigid limit by ~1e-8.
RIGID_EI = 1e9
#: Axial stiffness [N] of the sprinkler pipe: practically inextensible (the centrifugal
#: tension of ~10 N strains it by ~1e-9).
SPRINKLER_EA = 4e9


def sprinkler(*, EI: float, n_elements: int = 8, mass_flow: float = 10.0, radius: float = 0.5,
              pipe_mass: float = 0.5, fluid_mass: float = 1.0, kv: float = 1.0, rigid: bool = False,
              suck: bool = False, polar_inertia: float = 1e-4) -> Model:
    """Semicircular pipe rotating about its inlet, a garden sprinkler (seed 000, section
    3.3, Figs. 4-5).

    The inlet node sits at the origin on a hinge about global z; the semicircle of radius
    R lies in the xy plane with its centre at (R, 0, 0), leaving the inlet along +y and
    ending at (2R, 0, 0) pointing along -y. With ``suck=True`` the flow is reversed: the
    pipe draws fluid from a still reservoir at its free end (the elements' flow_factor is
    -1), where :meth:`ModelBuilder.reservoir_inlet` applies the additional inlet force.

    Args:
        EI: bending stiffness [N m^2] (ignored if ``rigid``).
        n_elements: curved elements. mass_flow: mdot [kg/s]. radius: R [m].
        pipe_mass: rho_p A_p [kg/m]. fluid_mass: rho_f A_f [kg/m]. kv: [-].
        rigid: use EI = RIGID_EI (a practically rigid pipe).
        suck: reverse the flow (the pipe sucks from a still reservoir).
        polar_inertia: rho I_p [kg m] rotary inertia per length about the pipe axis; it
            makes the mass matrix regular and does not enter the planar motion.
    """
    R = _checks.positive("radius", radius)
    EI = RIGID_EI if rigid else _checks.positive("EI", EI)
    sec = PipeSection(EI=EI, EA=SPRINKLER_EA, GJ=EI / 1.3, pipe_mass=pipe_mass, fluid_mass=fluid_mass, kv=kv,
                      rotary_inertia=(_checks.non_negative("polar_inertia", polar_inertia), 0.0, 0.0))
    b = ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_arc(n0, center=(R, 0.0, 0.0), angle=-np.pi, normal=(0.0, 0.0, 1.0), n_elements=n_elements,
                      section=sec, flow_factor=-1.0 if suck else 1.0)
    b.hinge(n0, (0.0, 0.0, 1.0))
    if suck:
        b.reservoir_inlet(nodes[-1])
    return b.build(mass_flow=_checks.finite("mass_flow", mass_flow))


def coriolis_meter(*, leg_length: float, fluid_density: float = 1000.0, mass_flow: float = 0.0,
                   radius: float = 0.150, elements_per_leg: int = 2, arc_elements: int = 12,
                   outer_diameter: float = 0.0508, inner_diameter: float = 0.0472, E: float = 208e9,
                   G: float = 80e9, density: float = 8027.0, kv: float = 1.0, drive_force: float = 0.0) -> Model:
    """U-shaped Coriolis mass-flow rate meter pipe (seed 000, section 4, Figs. 6-8).

    Geometry (flow order = node order): the U lies in the global xy plane and vibrates
    mainly out of it, along global z. The inlet leg is clamped at node 0 at (0, -a, 0) and
    runs along +x to (b, -a, 0) = S1; the semicircular arc of radius a, centred at
    (b, 0, 0), turns by +pi about +z through (b + a, 0, 0) to (b, a, 0) = S2; the outlet
    leg runs back along -x to the clamped outlet node at (0, a, 0). The arc is made of
    curved, stress-free elements whose end tangents match the legs (local z along +z).
    The sensors are the two ends of the arc: S1 is node ``elements_per_leg`` (inlet side)
    and S2 is node ``elements_per_leg + arc_elements`` (outlet side); the last node,
    ``2 * elements_per_leg + arc_elements``, is the clamped outlet. The cross-section's
    rotary inertia is included (a real tube); shear flexibility is not; no gravity.

    Args:
        leg_length: b [m] length of each straight leg.
        fluid_density: rho_f [kg/m^3] fluid density (water 1000, kerosene 780).
        mass_flow: mdot [kg/s] default prescribed mass flow of the model.
        radius: a [m] radius of the semicircular arc (centre line).
        elements_per_leg: [-] equal straight elements per leg (seed: 2).
        arc_elements: [-] equal curved elements in the arc (seed: 12).
        outer_diameter: D_o [m] tube outer diameter (seed: 50.8 mm).
        inner_diameter: D_i [m] tube inner diameter (seed: 47.2 mm).
        E: E [Pa] Young's modulus of the wall (steel, 208 GPa).
        G: G [Pa] shear modulus of the wall (80 GPa).
        density: rho_p [kg/m^3] density of the wall (8027).
        kv: k_v [-] momentum-flux factor (1: plug flow).
        drive_force: F [N] out-of-plane (+z) force at the arc's apex, node
            ``elements_per_leg + arc_elements // 2``: the meter's driver (scale it in time
            with ``simulate(..., load_factor=pf.Sine(...))``).
    """
    b_len = _checks.positive("leg_length", leg_length)
    a = _checks.positive("radius", radius)
    rho_f = _checks.non_negative("fluid_density", fluid_density)
    n_leg = _checks.positive_int("elements_per_leg", elements_per_leg)
    n_arc = _checks.positive_int("arc_elements", arc_elements)
    sec = PipeSection.tube(outer_diameter=outer_diameter, inner_diameter=inner_diameter, E=E, G=G,
                           density=density, fluid_density=rho_f, kv=kv, rotary_inertia=True)
    b = ModelBuilder()
    inlet = b.add_node((0.0, -a, 0.0))
    leg1 = b.add_line(inlet, (b_len, -a, 0.0), n_leg, sec)
    # start tangent sign(angle) * z x (S1 - centre) = z x (-a y) = +a x: continues leg 1
    arc = b.add_arc(leg1[-1], center=(b_len, 0.0, 0.0), angle=np.pi, normal=(0.0, 0.0, 1.0),
                    n_elements=n_arc, section=sec)
    leg2 = b.add_line(arc[-1], (0.0, a, 0.0), n_leg, sec)
    b.clamp(inlet)
    b.clamp(leg2[-1])
    drive = _checks.finite("drive_force", drive_force)
    if drive != 0.0:
        b.add_load(arc[n_arc // 2], force=(0.0, 0.0, drive))
    return b.build(mass_flow=_checks.finite("mass_flow", mass_flow))


#: Seed 002, Table 1: the beams of its refs. 19 (eccentrically suspended) and 21.
SPIN_UP_BEAMS = {
    "ref19": dict(length=10.0, density=3.0e3, area=4.0e-4, second_moment=1.997e-7, E=7.0e10, hub_radius=1.0,
                  omega=6.0),
    "ref21": dict(length=8.0, density=2.767e3, area=7.299e-5, second_moment=8.214e-9, E=6.895e10, hub_radius=0.0,
                  omega=4.0),
}


def rotating_cantilever(*, n_elements: int = 10, formulation: str = "ancf", model: str = "A",
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
        model: ANCF elastic force model, ``"A"`` or ``"0"`` (ignored for ``"pipe"``).
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
    L = _checks.positive("length", length)
    EI = _checks.positive("EI", EI)
    rho_a = _checks.positive("mass_per_length", mass_per_length)
    s = _checks.positive("slenderness", slenderness)
    R = _checks.non_negative("hub_radius_ratio", hub_radius_ratio) * L
    N = _checks.non_negative("tip_mass_ratio", tip_mass_ratio)
    EA = s**2 * EI / L**2
    b = ModelBuilder()
    if formulation == "ancf":
        sec = PipeSection(EI=EI, EA=EA, pipe_mass=rho_a)
        nodes = b.add_ancf_beam((R, 0.0, 0.0), (R + L, 0.0, 0.0), n_elements, sec, elastic=model)
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
                  tip_node=nodes[-1], beam_nodes=tuple(nodes), formulation=formulation, elastic=model)
    return m


def spin_up_beam(*, reference: str = "ref21", n_elements: int = 2, model: str = "A",
                 omega: float = None, spin_up_time: float = 15.0) -> Model:
    """A beam of seed 002's Table 1 on a hub that spins it up by eq. 13 (Figs. 2-7).

    Args:
        reference: ``"ref19"`` (L = 10 m, eccentricity 1 m, Omega = 6 rad/s) or
            ``"ref21"`` (L = 8 m, hub at the beam's end; Omega = 2, 4, 10, 40 rad/s).
        n_elements: ANCF elements. model: elastic force model ``"A"`` or ``"0"``.
        omega: final rate Omega [rad/s] (default: the reference's, 6 or 4 rad/s).
        spin_up_time: T [s] (the seed's 15 s).
    """
    if reference not in SPIN_UP_BEAMS:
        raise ValueError(f"reference must be one of {sorted(SPIN_UP_BEAMS)}, got {reference!r}")
    p = SPIN_UP_BEAMS[reference]
    L, rho_a = p["length"], p["density"] * p["area"]
    EI, EA = p["E"] * p["second_moment"], p["E"] * p["area"]
    w = p["omega"] if omega is None else _checks.finite("omega", omega)
    return rotating_cantilever(n_elements=n_elements, model=model, hub_radius_ratio=p["hub_radius"] / L,
                               slenderness=L * np.sqrt(EA / EI), length=L, EI=EI, mass_per_length=rho_a,
                               omega=w, spin_up_time=spin_up_time)


# -- seed 004: floating frame of reference -----------------------------------------------

def _tube(*, outer_diameter, inner_diameter, E, G, density, fluid_density) -> PipeSection:
    """A tube with its polar rotary inertia rho_p I_p (the torsion of floating-frame bodies
    needs it: without it the twist is a massless coordinate), bending rotary inertia 0."""
    sec = PipeSection.tube(outer_diameter=outer_diameter, inner_diameter=inner_diameter, E=E, G=G,
                           density=density, fluid_density=fluid_density, rotary_inertia=True)
    return dataclasses.replace(sec, rotary_inertia=(sec.rotary_inertia[0], 0.0, 0.0))


def _ffrf_chain(bodies, placements, flow_factor=1.0):
    """Bodies placed at (position, rotation), each rigidly joined to the next (end to start)."""
    from .multibody import MultibodyBuilder

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
                         reduction: str = "craig_bampton", mass_flow: float = 0.0, tip_force: float = 0.0,
                         length: float = 1.0, section: PipeSection = None):
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
        reduction: ``"craig_bampton"`` or ``"full"``. mass_flow: mdot [kg/s].
        tip_force: [N] along global z at the free end. length: L [m].
        section: replaces the default :class:`~pipeflex.PipeSection`.

    Returns a :class:`~pipeflex.multibody.MultibodySystem`; ``info["tip"]`` = (body, node).
    """
    from .multibody import flexible_body

    nb = _checks.positive_int("n_bodies", n_bodies)
    L = _checks.positive("length", length)
    if section is None:
        tube = _tube(outer_diameter=0.06197, inner_diameter=0.05046, E=24.64e6, G=9.48e6, density=7870.0,
                     fluid_density=1000.0)
        section = PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=tube.EA, GJ=tube.GJ,
                              rotary_inertia=tube.rotary_inertia)
    body = flexible_body(length=L / nb, n_elements=_elements_per_body(elements_per_body), section=section,
                         internal_modes=internal_modes, reduction=reduction)
    b, ids = _ffrf_chain([body] * nb, [(((k + 0.5) * L / nb, 0.0, 0.0), None) for k in range(nb)])
    b.fix(ids[0], "start")
    if tip_force:
        b.add_load(ids[-1], "end", force=(0.0, 0.0, _checks.finite("tip_force", tip_force)))
    system = b.build(mass_flow=mass_flow)
    system.info.update(tip=(ids[-1], body.n_elements), scene="seed 004, sec. 8.1")
    return system


#: Seed 004, Table 1: final angular velocity [rad/s] of the semicircular pipe, FFRF column.
FFRF_CURVED_TABLE1 = {0.9585e9: 5.320, 9.585e9: 9.117, 95.85e9: 9.954}


def ffrf_curved_pipe(*, E: float, n_bodies: int = 8, elements_per_body: int = 20, internal_modes: int = 0,
                     flow_speed: float = 10.0, radius: float = 0.5, reduction: str = "craig_bampton"):
    """Semicircular pipe hinged at its inlet (seed 004, section 8.2; seed 000's sprinkler).

    The semicircle of radius R lies in the global x-z plane: it leaves the hinge at the
    origin along +z, has its centre at (R, 0, 0) and ends at (2R, 0, 0). The hinge turns
    about global y. Tube: OD 36.80 mm, ID 35.68 mm, 7870 kg/m^3, Young's modulus E [Pa],
    nu = 0.3; water (1000 kg/m^3) at ``flow_speed`` sdot [m/s] relative to the pipe.
    Each body is straight with the arc preimposed (eta0) and made stress-free.

    Args:
        E: Young's modulus [Pa] (seed: 0.9585e9, 9.585e9, 95.85e9).
        n_bodies: bodies along the semicircle. elements_per_body: elements per body.
        internal_modes: Craig-Bampton internal modes per body. flow_speed: sdot [m/s].
        radius: R [m]. reduction: ``"craig_bampton"`` or ``"full"``.

    Returns a :class:`~pipeflex.multibody.MultibodySystem` whose mass flow is mu_f sdot.
    """
    from .multibody import flexible_body

    E = _checks.positive("E", E)
    R = _checks.positive("radius", radius)
    nb = _checks.positive_int("n_bodies", n_bodies)
    if nb < 2:
        raise ValueError(f"n_bodies must be >= 2 (a body spans less than 180 degrees of the semicircle), got {nb}")
    sec = _tube(outer_diameter=0.0368, inner_diameter=0.03568, E=E, G=E / 2.6, density=7870.0,
                fluid_density=1000.0)
    Lb = np.pi * R / nb
    body = flexible_body(length=Lb, n_elements=_elements_per_body(elements_per_body), section=sec, internal_modes=internal_modes,
                         reduction=reduction, curvature=1.0 / R)
    places = []
    for k in range(nb):
        th = (k + 0.5) * np.pi / nb
        pos = (R - R * np.cos(th), 0.0, R * np.sin(th))
        ex = np.array([np.sin(th), 0.0, np.cos(th)])   # tangent (flow direction)
        ey = np.array([np.cos(th), 0.0, -np.sin(th)])  # towards the centre
        places.append((pos, np.column_stack([ex, ey, np.cross(ex, ey)])))
    b, ids = _ffrf_chain([body] * nb, places)
    b.hinge(ids[0], "start", (0.0, 1.0, 0.0))
    system = b.build(mass_flow=sec.fluid_mass * _checks.finite("flow_speed", flow_speed))
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


def concrete_printer(*, flow_speed: float, gravity: float = 9.81, junction_forces: bool = True):
    """The concrete-printing robot of seed 004, section 8.3 (Figs. 11-12).

    Arm: four solid steel rods (diameter 4 cm, 7870 kg/m^3, E = 200 GPa, G = 77 GPa),
    OA (0.15 m, 4 elements), AB (0.30 m, 10), BC (0.15 m, 4), CD (0.40 m, 14); hinges at O
    (global z, driven by M_O = 353 t sin(8 pi t) N m), at A (axis normal to the plane of OA
    and AB, driven by M_A = -5000 cos(1.5 pi t) N m, a motor between OA and AB), at C
    (normal to BC, CD); AB and BC rigidly joined at B; a roller holds the height of the
    nozzle D. Pipe: PET tube (OD 4 cm, ID 3.5 cm, 1330 kg/m^3, E = 3.4 GPa, G = 1.2 GPa),
    bodies OE, EB (0.20 m), BF, FD (0.28 m), 4 elements each, rigidly joined, hinged
    about global z at O and attached at B and D with free orientation. Concrete
    (2400 kg/m^3) flows from O to the nozzle at ``flow_speed`` sdot [m/s]. Gravity
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
    from .multibody import MultibodyBuilder, flexible_body

    sdot = _checks.finite("flow_speed", flow_speed)
    g = _checks.non_negative("gravity", gravity)
    rod = PipeSection.tube(outer_diameter=0.04, inner_diameter=0.0, E=200e9, G=77e9, density=7870.0,
                           rotary_inertia=True)
    rod = dataclasses.replace(rod, rotary_inertia=(rod.rotary_inertia[0], 0.0, 0.0))
    tube = _tube(outer_diameter=0.04, inner_diameter=0.035, E=3.4e9, G=1.2e9, density=1330.0, fluid_density=2400.0)
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
        body = flexible_body(length=float(np.linalg.norm(q - p)), n_elements=4, section=tube)
        pipe[name] = b.add_body_between(body, p, q, up=(0.0, 1.0, 0.0))
    z, y = (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)
    from .analysis.transient import Sine

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
    system = b.build(mass_flow=tube.fluid_mass * sdot, junction_forces=junction_forces)
    system.info.update(nozzle=(arm["CD"], 14), arm=arm, pipe=pipe, points=P, flow_speed=sdot,
                       scene="seed 004, sec. 8.3")
    return system
