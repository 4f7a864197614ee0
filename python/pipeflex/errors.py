"""Exceptions raised by pipeflex analyses."""


class ConvergenceError(RuntimeError):
    """A solver failed; the message says where (load factor, time, iteration) and why."""
