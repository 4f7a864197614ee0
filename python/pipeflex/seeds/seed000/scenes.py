"""Seed 000 (Meijaard & Hakvoort): its test problems as models with the seed's values."""
from __future__ import annotations

import numpy as np

from ... import _checks
from ...model import Model, ModelBuilder
from ...sections import PipeSection


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
    L = _checks.magnitude("length", length, "m")
    EI = _checks.magnitude("EI", EI, "N m^2")  # before EA is derived from it
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
    L = _checks.magnitude("length", length, "m")
    EI = _checks.magnitude("EI", EI, "N m^2")  # before EA is derived from it
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
    R = _checks.magnitude("radius", radius, "m")
    EI = RIGID_EI if rigid else _checks.magnitude("EI", EI, "N m^2")
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
    b_len = _checks.magnitude("leg_length", leg_length, "m")
    a = _checks.magnitude("radius", radius, "m")
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
