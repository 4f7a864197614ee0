"""Cross-section and material data of pipes and beams, as immutable dataclasses.

All quantities are SI. A :class:`PipeSection` holds the stiffness and mass per unit
length that the 3D pipe element needs; :meth:`PipeSection.tube` builds one from a
circular tube's geometry and materials.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, Optional, Tuple

from . import _checks


#: Largest momentum-flux factor k_v accepted [-] (physical profiles give 1 to 2).
KV_MAX = 10.0

#: The damping coefficients of a section and their units (each >= 0, default 0).
DAMPING_FIELDS = {"eta_bending": "s", "eta_torsion": "s", "eta_axial": "s", "c_ext": "N s/m^2"}


@dataclass(frozen=True)
class PipeSection:
    """Properties of a pipe (or beam, with ``fluid_mass = 0``) cross-section.

    Attributes:
        EI: ``E I_y`` [N m^2] bending stiffness about the section's local y axis (for the
            planar ANCF beam, which bends about z only, the out-of-plane stiffness: it
            is not used there except as the default of ``EIz``).
        EIz: ``E I_z`` [N m^2] bending stiffness about local z (default: ``EI``). The
            planar ANCF beam (:meth:`~pipeflex.ModelBuilder.add_ancf_beam`) bends about
            global z and reads ``EIz``: ``EI`` and ``EIz`` mean the same for every
            formulation (see ``docs/conventions.md``, Frames).
        EA: ``E A_p`` [N] axial stiffness. Default ``1e10 m^-2 * EI``: practically
            inextensible, as the pipes of the validation cases (an axial strain of order P/EA < 1e-9 then
            shifts a critical flow by less than the tables' last digit).
        GJ: ``k_x G I_p`` [N m^2] torsional stiffness (default: ``EI / 1.3``, a thin tube).
        GAy, GAz: ``k_y G A_p``, ``k_z G A_p`` [N] shear stiffnesses; ``None`` means
            rigid in shear (Euler-Bernoulli, ``Phi = 0`` in eq. 7 of Meijaard & Hakvoort).
        pipe_mass: ``rho_p A_p`` [kg/m] pipe mass per unit length.
        fluid_mass: ``rho_f A_f`` [kg/m] fluid mass per unit length.
        kv: ``k_v`` [-] momentum-flux factor of eq. 18 (1: plug flow, 4/3: laminar).
        rotary_inertia: ``(rho I_p, rho I_y, rho I_z)`` [kg m] mass moments of inertia per
            unit length about the local x, y, z axes, lumped at the nodes (default zero,
            as in Meijaard & Hakvoort's tables).
        eta_bending, eta_torsion, eta_axial: ``eta`` [s] Kelvin-Voigt retardation times of
            the internal damping, stress = E (eps + eta eps_dot) for the bending, torsional
            and axial generalised strains (default 0: undamped). A mode of angular frequency
            omega [rad/s] dominated by bending gets the damping ratio eta_bending omega / 2.
        c_ext: ``c`` [N s/m^2] external viscous damping per unit length: a distributed
            force -c times the centre line's velocity (default 0).
        k_found: ``k_f`` [N/m^2] elastic (Winkler) foundation stiffness per unit length: a
            distributed force -k_f (r - r0) pulling the centre line r back to its position
            r0 as built, in every direction (default 0: no foundation). Its energy is
            elastic energy.
        outer_diameter: ``D_o`` [m] > 0 of the tube, or None (default): geometry for
            drawing only (the tube radius of :meth:`~pipeflex.TransientResult.to_vtk`);
            no formulation reads it. :meth:`tube` sets it.

    Which formulation reads what: the 3D pipe element reads every field; the
    floating-frame body (:func:`~pipeflex.multibody.flexible_body`) has no shear
    flexibility and plug flow, reads ``k_found`` (the foundation under its centre line as
    placed), and refuses ``GAy``, ``GAz``, ``kv != 1`` and the damping coefficients (its
    modes take ``modal_damping`` ratios instead); the planar
    ANCF beam reads ``EA``, ``EIz``, ``pipe_mass``, ``eta_axial``, ``eta_bending``,
    ``c_ext`` and ``k_found`` and refuses ``fluid_mass``, ``kv``, ``GAy``, ``GAz``, ``rotary_inertia``, ``eta_torsion``
    and a ``GJ`` other than its default.
    A field a formulation cannot honour is refused by name, never silently dropped.
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
    eta_bending: float = 0.0
    eta_torsion: float = 0.0
    eta_axial: float = 0.0
    c_ext: float = 0.0
    k_found: float = 0.0
    outer_diameter: Optional[float] = None

    def __post_init__(self):
        ok = _checks
        object.__setattr__(self, "EI", ok.magnitude("EI", self.EI, "N m^2"))
        object.__setattr__(self, "EIz", ok.magnitude("EIz", self.EI if self.EIz is None else self.EIz, "N m^2"))
        object.__setattr__(self, "EA", ok.magnitude("EA", 1e10 * self.EI if self.EA is None else self.EA, "N"))
        object.__setattr__(self, "GJ", ok.magnitude("GJ", self.EI / 1.3 if self.GJ is None else self.GJ, "N m^2"))
        for name in ("GAy", "GAz"):
            v = getattr(self, name)
            if v is not None:
                object.__setattr__(self, name, ok.magnitude(name, v, "N"))
        for name in ("pipe_mass", "fluid_mass"):
            v = ok.non_negative(name, getattr(self, name))
            object.__setattr__(self, name, ok.magnitude(name, v, "kg/m") if v > 0 else v)
        if self.pipe_mass + self.fluid_mass <= 0.0:
            raise ValueError("pipe_mass + fluid_mass must be > 0 (a massless section has no dynamics)")
        kv = ok.positive("kv", self.kv)
        if kv > KV_MAX:  # E[u^2]/E[u]^2 of a velocity profile: 1 (plug) to 2 (Poiseuille, by area)
            raise ValueError(f"kv must be in (0, {KV_MAX:g}] (momentum-flux factor: 1 plug flow, 4/3 laminar), "
                             f"got {kv:g}")
        object.__setattr__(self, "kv", kv)
        if isinstance(self.rotary_inertia, (str, bytes)) or not hasattr(self.rotary_inertia, "__len__") \
                or len(self.rotary_inertia) != 3:
            raise ValueError(f"rotary_inertia must be 3 numbers (rho I_p, rho I_y, rho I_z) [kg m] about local x, y, "
                             f"z, got {self.rotary_inertia!r} (leave it out for none: (0, 0, 0))")
        ri = tuple(ok.non_negative(f"rotary_inertia[{i}]", x) for i, x in enumerate(self.rotary_inertia))
        object.__setattr__(self, "rotary_inertia", ri)
        for name, unit in DAMPING_FIELDS.items():
            try:
                object.__setattr__(self, name, ok.non_negative(name, getattr(self, name)))
            except ValueError as err:
                raise ValueError(f"{err} ({name} [{unit}] is a damping coefficient: 0 for none)") from None
        try:
            object.__setattr__(self, "k_found", ok.non_negative("k_found", self.k_found))
        except ValueError as err:
            raise ValueError(f"{err} (k_found [N/m^2] is a foundation stiffness per length: 0 for none)") from None
        if self.outer_diameter is not None:
            object.__setattr__(self, "outer_diameter", ok.magnitude("outer_diameter", self.outer_diameter, "m"))

    @property
    def damped(self) -> bool:
        """Whether any damping coefficient (``eta_*``, ``c_ext``) is non-zero."""
        return any(getattr(self, name) != 0.0 for name in DAMPING_FIELDS)

    @classmethod
    def tube(cls, *, outer_diameter: float, inner_diameter: float, E: float, G: float,
             density: float, fluid_density: float = 0.0, kv: float = 1.0,
             shear: bool = False, rotary_inertia: bool = False,
             fluid_bulk_modulus: Optional[float] = None) -> "PipeSection":
        """Thin or thick circular tube.

        Args:
            outer_diameter: D_o [m]; inner_diameter: D_i [m] (0 for a solid rod).
            E: Young's modulus [Pa]; G: shear modulus [Pa].
            density: rho_p [kg/m^3] of the pipe wall; fluid_density: rho_f [kg/m^3].
            kv: momentum-flux factor [-].
            shear: include shear flexibility (shear coefficient of a thin tube, 0.5).
            rotary_inertia: lump the cross-section's rotary inertia at the nodes.
            fluid_bulk_modulus: K [Pa] of the fluid. If given, the pressure coupling of
                eq. 8 of Meijaard & Hakvoort is included: with the flow prescribed (no fluid
                accumulates, eps_7 = 0) the enclosed fluid resists the Poisson change of
                the bore, which stiffens the pipe axially to
                EA / (1 - (1 - 2 nu)^2 / (5 - 4 nu + 2 E t / (K r))),
                nu = E/(2G) - 1, t the wall thickness, r the mean radius; this needs an
                isotropic wall, -1 < nu <= 0.5 (else ValueError naming Poisson's ratio).

        Warns:
            UnitWarning: a value far outside its plausible SI range, as a unit slip
                gives (``outer_diameter`` > 5 m: millimetres?; ``E`` or ``G`` < 1e5 Pa:
                GPa?; ``density`` < 50 kg/m^3: g/cm^3?; see ``_checks.PLAUSIBLE`` and
                docs/conventions.md, Units). The value is used as given.
        """
        Do = _checks.positive("outer_diameter", outer_diameter)
        Di = _checks.non_negative("inner_diameter", inner_diameter)
        if Di >= Do:
            raise ValueError(f"inner_diameter must be < outer_diameter, got {Di} >= {Do}")
        E = _checks.positive("E", E)
        G = _checks.positive("G", G)
        rho = _checks.positive("density", density)
        rho_f = _checks.non_negative("fluid_density", fluid_density)
        # a unit slip (mm, GPa, g/cm^3) gives a valid but absurd section: warn, naming it
        _checks.unit_slip("outer_diameter", Do, "m", "diameter")
        for name, x in (("E", E), ("G", G)):
            _checks.unit_slip(name, x, "Pa", "modulus")
        _checks.unit_slip("density", rho, "kg/m^3", "density")
        _checks.unit_slip("fluid_density", rho_f, "kg/m^3", "fluid_density")
        if fluid_bulk_modulus is not None:
            _checks.unit_slip("fluid_bulk_modulus", _checks.positive("fluid_bulk_modulus", fluid_bulk_modulus), "Pa",
                              "bulk_modulus")
        A = math.pi / 4 * (Do**2 - Di**2)
        Af = math.pi / 4 * Di**2
        I = math.pi / 64 * (Do**4 - Di**4)
        k_shear = 0.5 if Di > 0 else 0.9
        EA = E * A
        if fluid_bulk_modulus is not None:
            EA = E * A * pressure_coupling_factor(E=E, G=G, wall=(Do - Di) / 2, radius=(Do + Di) / 4,
                                                  bulk_modulus=_checks.positive("fluid_bulk_modulus",
                                                                                fluid_bulk_modulus))
        return cls(EI=E * I, EA=EA, GJ=G * 2 * I,
                   GAy=k_shear * G * A if shear else None, GAz=k_shear * G * A if shear else None,
                   pipe_mass=rho * A, fluid_mass=rho_f * Af, kv=kv,
                   rotary_inertia=(2 * rho * I, rho * I, rho * I) if rotary_inertia else (0.0, 0.0, 0.0),
                   outer_diameter=Do)


def require_section(section, name: str = "section") -> PipeSection:
    """``section`` itself if it is a :class:`PipeSection`, else a TypeError naming
    ``name``, the type given and the remedy (a dict of fields: ``PipeSection(**d)``)."""
    if isinstance(section, PipeSection):
        return section
    hint = (f"make one from the dict: pipeflex.PipeSection(**{name})" if isinstance(section, dict)
            else "e.g. pipeflex.PipeSection(EI=..., pipe_mass=...) or pipeflex.PipeSection.tube(...)")
    raise TypeError(f"{name} must be a pipeflex.PipeSection, got {type(section).__name__} ({hint})")


def refuse_unsupported(section: PipeSection, reasons: Dict[str, str], where: str) -> None:
    """Raise ValueError naming every field in ``reasons`` that ``section`` sets to other
    than its default (``GAy``/``GAz`` None, ``kv`` 1, ``rotary_inertia`` zero, ``GJ``
    EI / 1.3, the damping coefficients and ``k_found`` 0): ``where`` would ignore it;
    ``reasons[name]`` says why."""
    default = {"GAy": None, "GAz": None, "kv": 1.0, "rotary_inertia": (0.0, 0.0, 0.0), "GJ": section.EI / 1.3,
               "k_found": 0.0, **{name: 0.0 for name in DAMPING_FIELDS}}
    shown = {"GJ": "EI / 1.3"}
    bad = [f"section.{name} = {getattr(section, name)!r}: {why} (leave it at its default, "
           f"{shown.get(name, repr(default[name]))})" for name, why in reasons.items()
           if getattr(section, name) != default[name]]
    if bad:
        raise ValueError(f"{where} cannot use this section; " + "; ".join(bad))


def pressure_coupling_factor(*, E: float, G: float, wall: float, radius: float, bulk_modulus: float) -> float:
    """Axial stiffening factor [-] of a fluid-filled thin tube with no fluid accumulation.

    From eq. 8 of Meijaard & Hakvoort, [eps1, eps7] = l0/(E A) [[1, c], [c, d]] [sigma1, sigma7] with
    c = 1 - 2 nu, d = 5 - 4 nu + 2 E t / (K r): setting eps7 = 0 eliminates the fluid
    force sigma7 = -c sigma1 / d and leaves eps1 = l0 (1 - c^2/d) sigma1 / (E A).

    Args:
        E, G: moduli of the wall [Pa]; wall: t [m]; radius: r [m] mean radius;
        bulk_modulus: K [Pa] of the fluid.
    """
    nu = E / (2.0 * G) - 1.0
    # an isotropic wall has -1 < nu <= 0.5; outside, 1 - c^2/d may vanish or change sign
    # (EA <= 0 or infinite) although the user gave no EA
    if not -1.0 < nu <= 0.5:
        raise ValueError(f"Poisson's ratio nu = E / (2 G) - 1 = {nu:.6g} (E = {E:g} Pa, G = {G:g} Pa) must be in "
                         f"(-1, 0.5] for the fluid pressure coupling of fluid_bulk_modulus (an isotropic wall): "
                         f"check E and G (G = E / (2 (1 + nu)), steel: E = 2.1e11 Pa, G = 8.1e10 Pa)")
    c = 1.0 - 2.0 * nu
    d = 5.0 - 4.0 * nu + 2.0 * E * wall / (bulk_modulus * radius)
    return 1.0 / (1.0 - c * c / d)
