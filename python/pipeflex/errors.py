"""Exceptions raised by pipeflex analyses."""
from __future__ import annotations

import re
from typing import Optional


class ConvergenceError(RuntimeError):
    """A solver failed; the message says where (load factor, time, iteration) and why.

    Attributes:
        time: the simulated time t [s] at which a time integration failed (None for
            other solvers).
    """

    def __init__(self, message: str, *, time: Optional[float] = None):
        super().__init__(message)
        self.time = time

    @classmethod
    def from_solver(cls, message: str) -> "ConvergenceError":
        """From a C++ integrator's message, which names the time as "t = <value> s"."""
        m = re.search(r"\bt = ([-+0-9.eE]+) s", message)
        return cls(message, time=float(m.group(1)) if m else None)
