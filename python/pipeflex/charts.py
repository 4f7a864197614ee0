"""The charts of the periodic orbits (:mod:`pipeflex.analysis.periodic`): each
formulation's coordinates z about a base state and their rates, what the shooting needs of
a formulation; the model classes give theirs (``_orbit_chart``).

- :class:`ElementChart`: an element model's reduced coordinates about a base State (its
  node frames held);
- :class:`BodyChart`: per body r - r_base, log(R R_base^T), eta - eta_base; rates the
  velocities (spatial angular velocities);
- :class:`CoupledChart`: both stacked [element; bodies] about a coupled static result.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .rotation import rotation_log
from .state import State, as_core


def _state_at(base: State, basis, z, v) -> State:
    return State(base.q + basis @ z, basis @ v, np.zeros_like(base.a), base.frames.copy(), base.ancf.copy())


class ElementChart:
    """An element model's reduced coordinates z (n_dofs) about a base State (node frames
    held) and their chart rates: what the shooting needs of a formulation (the other
    charts have the same members)."""

    #: orbit_guess runs pf.simulate on an element model (which re-bases its own frames);
    #: the other charts' guesses run the flow map re-based per chunk
    guess_by_simulate = True
    #: the coordinates are the linearisation's independent ones (no constraints)
    independent = True

    def __init__(self, model, base):
        self.model = self.element_model = model
        self.base = base if isinstance(base, State) else State.from_core(as_core(model, base), model)
        self.base.q.flags.writeable = False
        self.n = model.n_dofs
        self.length_scale = model.length_scale

    def system(self, mass_flow):
        """The core system at the base state."""
        return self.model.system(self.base.to_core(self.model), mass_flow=mass_flow)

    def positions(self, z):
        """(k, n_points, 3) positions [m] at the rows of z (k, n)."""
        q = self.base.q[None, :] + (self.model.basis @ np.atleast_2d(z).T).T
        return q.reshape(len(q), self.model.n_nodes, 6)[:, :, :3]

    def state(self, z, v):
        """The state at coordinates z with rates v."""
        return _state_at(self.base, self.model.basis, z, v)

    def coordinates(self, state):
        """(z, v) of a state (least squares through the basis)."""
        st = State.from_core(as_core(self.model, state), self.model)
        basis = self.model.basis
        return _reduced(basis, st.q - self.base.q, self.base, st), _reduced(basis, st.v, self.base, st)


class BodyChart:
    """A MultibodySystem's coordinates about a base MultibodyState: per body r - r_base,
    log(R R_base^T), eta - eta_base; rates its velocities (spatial angular velocities)."""

    guess_by_simulate = False
    independent = False
    element_model = None  # (no pipe elements whose missing inertia a singular mass explains)

    def __init__(self, model, base):
        model.check_state(base, "base")
        self.model = model
        self.base = base.copy()
        self.n = model.n_coordinates
        self.length_scale = model.length_scale

    def system(self, mass_flow):
        return self.model.system(self.base)

    def positions(self, z):
        out = []
        for zk in np.atleast_2d(z):
            st = self.base.copy()
            self.model.increment(st, zk)
            out.append(np.vstack(self.model.centre_line(st)))
        return np.array(out)

    def state(self, z, v):
        st = self.base.copy()
        self.model.increment(st, np.asarray(z, float))
        st.v[:] = v
        st.a[:] = 0.0
        return st

    def coordinates(self, state):
        self.model.check_state(state)
        z = np.asarray(state.eta, float) - self.base.eta
        for j, o in enumerate(self.model.offsets[:-1]):
            z[o:o + 3] = state.r[j] - self.base.r[j]
            z[o + 3:o + 6] = rotation_log(state.R[j] @ self.base.R[j].T)
        return z, np.array(state.v, float)


class CoupledChart:
    """A CoupledSystem's coordinates [element; bodies] about a base CoupledStatic (the
    element part as ElementChart, the bodies' as BodyChart); its states are
    CoupledStatic's fields with the rates."""

    guess_by_simulate = False
    independent = False

    def __init__(self, model, base):
        if not _coupled_static(base):
            raise TypeError(f"the state of a CoupledSystem's periodic orbit must be a CoupledStatic "
                            f"(pipeflex.static_equilibrium(system), or an orbit's start), got {type(base).__name__}")
        self.model = model
        self.base = base
        self.elements = ElementChart(model.model, base.state)
        self.element_model = model.model
        self.bodies = BodyChart(model.bodies, base.body_state)
        self.n = self.elements.n + self.bodies.n
        self.length_scale = max(self.elements.length_scale, self.bodies.length_scale)

    def system(self, mass_flow):
        return self.model.system(self.elements.base.to_core(self.model.model), self.bodies.base,
                                 self.base.coupling_forces, mass_flow=mass_flow)

    def positions(self, z):
        z = np.atleast_2d(z)
        n1 = self.elements.n
        return np.concatenate([self.elements.positions(z[:, :n1]), self.bodies.positions(z[:, n1:])], axis=1)

    def state(self, z, v):
        n1 = self.elements.n
        return replace(self.base, state=self.elements.state(z[:n1], v[:n1]),
                       body_state=self.bodies.state(z[n1:], v[n1:]))

    def coordinates(self, state):
        if not _coupled_static(state):
            raise TypeError(f"state must be a CoupledStatic for a CoupledSystem, got {type(state).__name__}")
        (z1, v1), (z2, v2) = self.elements.coordinates(state.state), self.bodies.coordinates(state.body_state)
        return np.concatenate([z1, z2]), np.concatenate([v1, v2])


def _coupled_static(state) -> bool:
    """Whether ``state`` holds a coupled system's parts and multipliers (a static result)."""
    return all(getattr(state, k, None) is not None for k in ("state", "body_state", "coupling_forces"))


def _reduced(basis, full, chart, start):
    if not np.allclose(chart.frames, start.frames, atol=1e-12):
        raise ValueError("state and base have different node frames: pass states in the same chart "
                         "(e.g. base=None)")
    # least squares through the sparse basis (its columns have full rank): the normal
    # equations stay sparse, where a dense basis would be (6 n_nodes x n_dofs)
    B = sp.csc_matrix(basis)
    return np.atleast_1d(spla.spsolve((B.T @ B).tocsc(), B.T @ full))
