"""Element models on floating-frame hub bodies: seed 000's sprinkler arm and seed 002's
rotating cantilever joined to a hub body with inertia (:class:`pipeflex.CoupledSystem`),
the acceptance scenes of the one engine."""
from __future__ import annotations

from typing import Tuple

import numpy as np

from ... import _checks
from ...coupled import CoupledSystem
from ...model import ModelBuilder
from ...multibody import MultibodyBuilder, flexible_body
from ...sections import PipeSection
from ..seed000.scenes import SPRINKLER_EA

#: Length [m] of the hub bodies: a stub ending at the hinge, on the far side of the arm.
HUB_LENGTH = 0.2


def _hub(inertia: float, *, axis=(0.0, 0.0, 1.0), torque=None, gravity=None):
    """A stiff hub body of ``inertia`` J [kg m^2] about its end, from (-HUB_LENGTH, 0, 0)
    to the origin, hinged to the ground there about ``axis`` (optional driving torque)."""
    J = _checks.positive("hub_inertia", inertia)
    mu = 3.0 * J / HUB_LENGTH**3  # a uniform rod: J = mu L^3 / 3 about its end
    sec = PipeSection(EI=1e3 * mu, pipe_mass=mu, rotary_inertia=(1e-3 * mu, 0.0, 0.0))
    mb = MultibodyBuilder()
    j = mb.add_body(flexible_body(length=HUB_LENGTH, n_elements=2, section=sec), position=(-HUB_LENGTH / 2, 0.0, 0.0))
    mb.hinge(j, "end", axis, torque=torque)
    if gravity is not None:
        mb.set_gravity(gravity)
    return mb.build(), j


def sprinkler_on_hub(*, EI: float = 100.0, n_elements: int = 8, mass_flow: float = 10.0, radius: float = 0.5,
                     hub_inertia: float = 0.0133) -> Tuple[CoupledSystem, int, int]:
    """Seed 000's sprinkler arm (:func:`pipeflex.scenes.sprinkler`: semicircle of radius R in
    the x-y plane from the origin, pipe 0.5 kg/m, fluid 1 kg/m) clamped at its inlet to a
    hub body of inertia J [kg m^2] hinged to the ground about z at the origin, instead of
    hinged there itself. Returns (system, the arm's inlet node, the hub body).

    Args: EI [N m^2]; n_elements; mass_flow mdot [kg/s]; radius R [m]; hub_inertia J
    [kg m^2] about the hinge (default: a 0.2 m stub of 5 kg/m).
    """
    R = _checks.magnitude("radius", radius, "m")
    EI = _checks.magnitude("EI", EI, "N m^2")
    sec = PipeSection(EI=EI, EA=SPRINKLER_EA, GJ=EI / 1.3, pipe_mass=0.5, fluid_mass=1.0,
                      rotary_inertia=(1e-4, 0.0, 0.0))
    b = ModelBuilder()
    inlet = b.add_node((0.0, 0.0, 0.0))
    b.add_arc(inlet, center=(R, 0.0, 0.0), angle=-np.pi, normal=(0.0, 0.0, 1.0), n_elements=n_elements, section=sec)
    arm = b.build(mass_flow=_checks.finite("mass_flow", mass_flow), floating=True)
    hub, j = _hub(hub_inertia)
    system = CoupledSystem(arm, hub)
    system.rigid(inlet, j, "end")
    return system, inlet, j


def spin_up_acceleration(t, *, omega: float, spin_up_time: float):
    """theta'' [rad/s^2] of seed 002's eq. 13 at times t [s]: Omega / T (1 - cos(2 pi t / T))
    while t < T, then 0."""
    t = np.asarray(t, float)
    return np.where(t < spin_up_time, omega / spin_up_time * (1 - np.cos(2 * np.pi * t / spin_up_time)), 0.0)


def beam_on_free_hub(*, hub_inertia: float, omega: float = 2.0, spin_up_time: float = 2.0, t_end: float = 3.0,
                     n_elements: int = 6, slenderness: float = 216.22,
                     torque_samples: int = 601) -> Tuple[CoupledSystem, list, int, Tuple[np.ndarray, np.ndarray]]:
    """Seed 002's rotating cantilever (:func:`pipeflex.scenes.rotating_cantilever`'s
    defaults: L = 1 m, EI = 1 N m^2, rho A = 1 kg/m, planar ANCF elements) clamped at its
    root to a hub body of inertia J [kg m^2] hinged about z, driven by the motor torque
    (J + m L^2 / 3) theta''(t) that would spin a rigid beam up by eq. 13 to ``omega``
    Omega [rad/s] in ``spin_up_time`` T [s] (a table over [0, t_end] with
    ``torque_samples`` points). As J grows the hub follows eq. 13 and the beam the
    prescribed-rate result. Returns (system, beam nodes, hub body, (t [s], torque [N m]))."""
    EI, rho_a, L = 1.0, 1.0, 1.0
    sec = PipeSection(EI=EI, EA=_checks.positive("slenderness", slenderness)**2 * EI / L**2, pipe_mass=rho_a)
    b = ModelBuilder()
    nodes = b.add_ancf_beam((0.0, 0.0, 0.0), (L, 0.0, 0.0), _checks.positive_int("n_elements", n_elements), sec)
    beam = b.build(floating=True)
    t = np.linspace(0.0, _checks.positive("t_end", t_end), _checks.positive_int("torque_samples", torque_samples))
    J = _checks.positive("hub_inertia", hub_inertia)
    torque = (J + rho_a * L**3 / 3.0) * spin_up_acceleration(t, omega=_checks.finite("omega", omega),
                                                              spin_up_time=_checks.positive("spin_up_time", spin_up_time))
    hub, j = _hub(J, torque=(t, torque))
    system = CoupledSystem(beam, hub)
    system.rigid(nodes[0], j, "end")
    return system, list(nodes), j, (t, torque)


def hub_frame_deflection(result, node: int, body: int) -> np.ndarray:
    """(n_out,) position [m] of element node ``node`` normal to the hub body's x axis, in
    the hub's frame (for a beam along the hub's x axis: its transverse deflection)."""
    R = result.bodies.R[:, body]
    theta = np.unwrap(np.arctan2(R[:, 1, 0], R[:, 0, 0]))
    normal = np.stack([-np.sin(theta), np.cos(theta), np.zeros_like(theta)], axis=1)
    return np.einsum("ij,ij->i", result.elements.x[:, node], normal)


def angular_momentum_z(result, system: CoupledSystem, beam_nodes, body: int, *, mass_per_length: float = 1.0) -> float:
    """Angular momentum about the z axis through the origin [kg m^2/s] at the run's end:
    the planar ANCF beam between ``beam_nodes`` (Hermite interpolation of its nodes) plus
    the hub body (its generalised momentum M v in the body frame)."""
    m = np.array([[13 / 35, 11 / 210, 9 / 70, -13 / 420], [11 / 210, 1 / 105, 13 / 420, -1 / 140],
                  [9 / 70, 13 / 420, 13 / 35, -11 / 210], [-13 / 420, -1 / 140, -11 / 210, 1 / 105]])
    q = np.asarray(result.elements.final_state.q).reshape(-1, 6)
    v = np.asarray(result.elements.final_state.v).reshape(-1, 6)
    H = 0.0
    for A, B in zip(beam_nodes[:-1], beam_nodes[1:]):
        l = float(np.linalg.norm(system.model.positions[B] - system.model.positions[A]))
        a = [q[A, :3], l * q[A, 3:], q[B, :3], l * q[B, 3:]]
        ad = [v[A, :3], l * v[A, 3:], v[B, :3], l * v[B, 3:]]
        H += mass_per_length * l * sum(m[i, k] * np.cross(a[i], ad[k])[2] for i in range(4) for k in range(4))
    hub = system.bodies
    st = result.bodies.state(len(result.t) - 1)
    o, e = hub.offsets[body], hub.offsets[body + 1]
    R = st.R[body]
    p = hub.bodies[body].data.M @ np.concatenate([R.T @ st.v[o:o + 3], R.T @ st.v[o + 3:o + 6], st.v[o + 6:e]])
    return float(H + (np.cross(st.r[body], R @ p[:3]) + R @ p[3:6])[2])
