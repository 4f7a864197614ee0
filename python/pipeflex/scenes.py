"""Every seed's test problems as ready-made models, with the seed's values as defaults.

A catalogue over :mod:`pipeflex.seeds` (seed 000: pipes with flow; seed 002: rotating
ANCF beams; seed 004: floating-frame pipe systems), kept as ``pipeflex.scenes``.

One vocabulary across them (all keyword-only): every scene that carries fluid takes
``mass_flow`` mdot [kg/s]; the seed-004 scenes, whose paper gives flow speeds, take
``flow_speed`` sdot [m/s] instead (mdot = rho_f A_f sdot; giving both is a ValueError);
the ANCF elastic force model is ``elastic`` (``"A"`` or ``"0"``; ``model=`` still works
with a DeprecationWarning). The seed-002 beams carry no fluid and take no flow.
"""
from .seeds.seed000.scenes import (RIGID_EI, SPRINKLER_EA, cantilever_pipe, coriolis_meter,
                                   simply_supported_pipe, sprinkler)
from .seeds.seed002.scenes import SPIN_UP_BEAMS, rotating_cantilever, spin_up_beam
from .seeds.seed004.scenes import (PRINTER_POINTS, concrete_printer, ffrf_cantilever_pipe,
                                   ffrf_curved_pipe)
from .seeds.seed004.coupled_scenes import beam_on_free_hub, sprinkler_on_hub

__all__ = ["RIGID_EI", "SPRINKLER_EA", "cantilever_pipe", "coriolis_meter", "simply_supported_pipe", "sprinkler",
           "SPIN_UP_BEAMS", "rotating_cantilever", "spin_up_beam", "PRINTER_POINTS", "concrete_printer",
           "ffrf_cantilever_pipe", "ffrf_curved_pipe", "sprinkler_on_hub", "beam_on_free_hub"]
