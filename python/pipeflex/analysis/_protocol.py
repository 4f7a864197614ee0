"""The protocol of the model classes that every analysis driver uses, one driver for every
formulation (an element :class:`~pipeflex.Model`, a
:class:`~pipeflex.multibody.MultibodySystem`, a :class:`~pipeflex.CoupledSystem`); each class
implements it, so the drivers name no formulation:

- ``_system(state=None, *, mass_flow=None)``: the core's system object (``_core.System``)
  on a copy of the formulation's user-level start state (None: the model's default start),
  mdot [kg/s] for the loads that depend on it (None: the model's);
- ``_state_of(system)``: the end state of an analysis run on it, in the user-level type;
- further methods with a leading underscore, each named for what it gives
  (``_linearization``, ``_transient_parts``, ``_rotation_hinge``, ...).

Option defaults are not per formulation: they live once in :mod:`pipeflex._options`.
"""
from __future__ import annotations

from ._assembly import require_model


def require_system(model, name: str = "model"):
    """``model`` if the analyses take it (it has the protocol: a :class:`~pipeflex.Model`,
    a :class:`~pipeflex.multibody.MultibodySystem` or a :class:`~pipeflex.CoupledSystem`),
    else the TypeError of :func:`~pipeflex.analysis._assembly.require_model` naming ``name``."""
    if not callable(getattr(model, "_system", None)):
        require_model(model, name)
    return model
