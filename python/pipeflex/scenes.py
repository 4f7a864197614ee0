"""The seeds' test problems as ready-made models (defaults are the seeds' values)."""
from __future__ import annotations

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
                    fluid_mass: float = 2.0, kv: float = 1.0, mass_flow: float = 0.0) -> Model:
    """Straight cantilever pipe clamped at the inlet, free jet at the outlet
    (seed 000, section 3.2, Fig. 2; Table 2). Along global x from the origin.

    Args:
        n_elements: number of equal elements.
        length: L [m]. EI: bending stiffness [N m^2]. pipe_mass: rho_p A_p [kg/m].
        fluid_mass: rho_f A_f [kg/m]. kv: momentum-flux factor [-]. mass_flow: mdot [kg/s].
    """
    L = _checks.positive("length", length)
    sec = PipeSection(EI=EI, pipe_mass=pipe_mass, fluid_mass=fluid_mass, kv=kv, EA=1e10 * EI / L**2)
    b = ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (L, 0.0, 0.0), n_elements, sec)
    b.clamp(n0)
    return b.build(mass_flow=mass_flow)
