"""The state of a :class:`~pipeflex.Model` as plain arrays (the core's ``State`` in numpy).

Conversion to and from the compiled ``_core.State`` copies the numbers exactly, so a
state saved, pickled or passed between models (of the same node count) gives
bit-identical analyses.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .results import Result
from .rotation import planar_triad, rotation_exp


@dataclass(frozen=True)
class State(Result):
    """Configuration and motion of a model's nodes (6 coordinates per node, see
    ``docs/conventions.md``).

    Attributes:
        q: (6 n_nodes,) coordinates: per frame node x [m] and the rotation vector phi
            [rad] relative to its reference frame; per ANCF node x [m] and the slope
            dr/dx [-].
        v: (6 n_nodes,) their time derivatives [m/s, rad/s, 1/s].
        a: (6 n_nodes,) second time derivatives [m/s^2, rad/s^2, 1/s^2].
        frames: (n_nodes, 3, 3) reference rotation of each node [-] (the orientation is
            exp(phi) frames[n]; re-based as rotations grow; identity for ANCF nodes).
        ancf: (n_nodes,) True for the ANCF nodes (the model's ``ancf_nodes``).
    """

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    frames: np.ndarray
    ancf: np.ndarray

    @property
    def n_nodes(self) -> int:
        return len(self.frames)

    @classmethod
    def from_core(cls, state, model) -> "State":
        """A copy of a ``_core.State`` of ``model``."""
        n = model.n_nodes
        ancf = np.zeros(n, dtype=bool)
        ancf[list(model.ancf_nodes)] = True
        return cls(np.array(state.q, dtype=float), np.array(state.v, dtype=float), np.array(state.a, dtype=float),
                   state.frames, ancf)

    def to_core(self, model) -> "_core.State":
        """A new ``_core.State`` of ``model`` holding these values."""
        n = model.n_nodes
        for name, shape in (("q", (6 * n,)), ("v", (6 * n,)), ("a", (6 * n,)), ("frames", (n, 3, 3))):
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"state.{name} must have shape {shape} for this model ({n} nodes), "
                                 f"got {np.shape(getattr(self, name))}")
        if sorted(np.flatnonzero(self.ancf)) != sorted(model.ancf_nodes):
            raise ValueError("the state's ANCF nodes differ from the model's")
        bad = np.flatnonzero(~np.isfinite(np.asarray(self.frames, float).reshape(n, 9)).all(axis=1))
        if len(bad):
            raise ValueError(f"state.frames[{bad[0]}] must be finite")
        s = _core.State(model.core)
        s.q, s.v, s.a = self.q, self.v, self.a
        s.frames = self.frames
        return s

    def frame(self, node: int) -> np.ndarray:
        """Reference rotation (3 x 3) of ``node``."""
        return self.frames[node].copy()

    def rotation(self, node: int) -> np.ndarray:
        """Rotation matrix (3 x 3) of ``node``: exp(phi) frames[node]; at an ANCF node the
        triad with e1 along the slope and e3 = z."""
        d = self.q[6 * node + 3:6 * node + 6]
        return planar_triad(d) if self.ancf[node] else rotation_exp(d) @ self.frames[node]

    def copy(self) -> "State":
        """A deep copy."""
        return State(self.q.copy(), self.v.copy(), self.a.copy(), self.frames.copy(), self.ancf.copy())


def as_core(model, state) -> "_core.State":
    """A fresh ``_core.State`` for the solvers: the model's reference state if ``state``
    is None, else a copy of ``state`` (a :class:`State` or a ``_core.State``)."""
    if state is None:
        return model.initial_state()
    if isinstance(state, State):
        core = state.to_core(model)
    elif isinstance(state, _core.State):
        if len(state.q) != 6 * model.n_nodes:
            raise ValueError(f"the state has {len(state.q)} coordinates, the model {6 * model.n_nodes} "
                             f"(6 per node)")
        core = state.copy()
    else:
        raise ValueError(f"state must be a pipeflex.state.State (or a model's initial_state()), "
                         f"got {type(state).__name__}")
    check_finite(core)
    return core


def check_finite(state) -> None:
    """ValueError naming the first non-finite entry of a ``_core.State``'s q, v or a (the
    solvers' convergence tests cannot hold with NaN or inf). The frames are checked where
    they enter from numpy (:meth:`State.to_core`); the core only writes finite ones from
    finite coordinates, and reading them node by node would make every analysis call
    cost O(nodes) Python calls."""
    for name in ("q", "v", "a"):
        x = np.asarray(getattr(state, name))
        bad = np.flatnonzero(~np.isfinite(x))
        if len(bad):
            raise ValueError(f"state.{name} must be finite, got {x[bad[0]]} at index {bad[0]} "
                             f"(node {bad[0] // 6}, coordinate {bad[0] % 6})")
