"""Cross-section and material data of pipes and beams, as immutable dataclasses.

All quantities are SI. A :class:`PipeSection` holds the stiffness and mass per unit
length that the element of seed 000 needs; :meth:`PipeSection.tube` builds one from a
circular tube's geometry and materials.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Tuple

from . import _checks


@dataclass(frozen=True)
class PipeSection:
    """Properties of a pipe (or beam, with ``fluid_mass = 0``) cross-section.

    Attributes:
        EI: ``E I_y`` [N m^2] bending stiffness about the section's local y axis.
        EIz: ``E I_z`` [N m^2] bending stiffness about local z (default: ``EI``).
        EA: ``E A_p`` [N] axial stiffness. Default ``1e10 m^-2 * EI``: practically
            inextensible, as the seed's pipes (an axial strain of order P/EA < 1e-9 then
            shifts a critical flow by less than the tables' last digit).
        GJ: ``k_x G I_p`` [N m^2] torsional stiffness (default: ``EI / 1.3``, a thin tube).
        GAy, GAz: ``k_y G A_p``, ``k_z G A_p`` [N] shear stiffnesses; ``None`` means
            rigid in shear (Euler-Bernoulli, ``Phi = 0`` in eq. 7 of seed 000).
        pipe_mass: ``rho_p A_p`` [kg/m] pipe mass per unit length.
        fluid_mass: ``rho_f A_f`` [kg/m] fluid mass per unit length.
        kv: ``k_v`` [-] momentum-flux factor of eq. 18 (1: plug flow, 4/3: laminar).
        rotary_inertia: ``(rho I_p, rho I_y, rho I_z)`` [kg m] mass moments of inertia per
            unit length about the local x, y, z axes, lumped at the nodes (default zero,
            as in the seed's tables).
    """

    EI: float
    pipe_mass: float
    fluid_mass: float = 0.0
    EIz: Optional[float] = None
    EA: Optional[float] = None
    GJ: Optional[float] = None
    GAy: Optional[float] = None
    GAz: Optional[float] = None
    kv: float = 1.0
    rotary_inertia: Tuple[float, float, float] = field(default=(0.0, 0.0, 0.0))

    def __post_init__(self):
        ok = _checks
        object.__setattr__(self, "EI", ok.positive("EI", self.EI))
        object.__setattr__(self, "EIz", ok.positive("EIz", self.EI if self.EIz is None else self.EIz))
        object.__setattr__(self, "EA", ok.positive("EA", 1e10 * self.EI if self.EA is None else self.EA))
        object.__setattr__(self, "GJ", ok.positive("GJ", self.EI / 1.3 if self.GJ is None else self.GJ))
        for name in ("GAy", "GAz"):
            v = getattr(self, name)
            if v is not None:
                object.__setattr__(self, name, ok.positive(name, v))
        object.__setattr__(self, "pipe_mass", ok.non_negative("pipe_mass", self.pipe_mass))
        object.__setattr__(self, "fluid_mass", ok.non_negative("fluid_mass", self.fluid_mass))
        if self.pipe_mass + self.fluid_mass <= 0.0:
            raise ValueError("pipe_mass + fluid_mass must be > 0 (a massless section has no dynamics)")
        object.__setattr__(self, "kv", ok.positive("kv", self.kv))
        ri = tuple(ok.non_negative(f"rotary_inertia[{i}]", x) for i, x in enumerate(self.rotary_inertia))
        if len(ri) != 3:
            raise ValueError("rotary_inertia must have 3 entries (about local x, y, z) [kg m]")
        object.__setattr__(self, "rotary_inertia", ri)

    @classmethod
    def tube(cls, *, outer_diameter: float, inner_diameter: float, E: float, G: float,
             density: float, fluid_density: float = 0.0, kv: float = 1.0,
             shear: bool = False, rotary_inertia: bool = False) -> "PipeSection":
        """Thin or thick circular tube.

        Args:
            outer_diameter: D_o [m]; inner_diameter: D_i [m] (0 for a solid rod).
            E: Young's modulus [Pa]; G: shear modulus [Pa].
            density: rho_p [kg/m^3] of the pipe wall; fluid_density: rho_f [kg/m^3].
            kv: momentum-flux factor [-].
            shear: include shear flexibility (shear coefficient of a thin tube, 0.5).
            rotary_inertia: lump the cross-section's rotary inertia at the nodes.
        """
        Do = _checks.positive("outer_diameter", outer_diameter)
        Di = _checks.non_negative("inner_diameter", inner_diameter)
        if Di >= Do:
            raise ValueError(f"inner_diameter must be < outer_diameter, got {Di} >= {Do}")
        E = _checks.positive("E", E)
        G = _checks.positive("G", G)
        rho = _checks.positive("density", density)
        rho_f = _checks.non_negative("fluid_density", fluid_density)
        A = math.pi / 4 * (Do**2 - Di**2)
        Af = math.pi / 4 * Di**2
        I = math.pi / 64 * (Do**4 - Di**4)
        k_shear = 0.5 if Di > 0 else 0.9
        return cls(EI=E * I, EA=E * A, GJ=G * 2 * I,
                   GAy=k_shear * G * A if shear else None, GAz=k_shear * G * A if shear else None,
                   pipe_mass=rho * A, fluid_mass=rho_f * Af, kv=kv,
                   rotary_inertia=(2 * rho * I, rho * I, rho * I) if rotary_inertia else (0.0, 0.0, 0.0))
