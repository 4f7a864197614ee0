"""Every seed's test problems as ready-made models, with the seed's values as defaults.

A catalogue over :mod:`pipeflex.seeds` (seed 000: pipes with flow; seed 002: rotating
ANCF beams; seed 004: floating-frame pipe systems), kept as ``pipeflex.scenes``.

One vocabulary across them (all keyword-only): every scene that carries fluid takes
``mass_flow`` mdot [kg/s]; the seed-004 scenes, whose paper gives flow speeds, take
``flow_speed`` sdot [m/s] instead (mdot = rho_f A_f sdot; giving both is a ValueError);
the ANCF elastic force model is ``elastic`` (``"A"`` or ``"0"``; ``model=`` still works
with a DeprecationWarning). The seed-002 beams carry no fluid and take no flow.
"""
from typing import TYPE_CHECKING

from . import _lazy

# each seed's scenes load on first use: an element scene does not import the floating-frame
# bodies or scipy (docs/performance.md)
_LAZY = {
    "RIGID_EI": "pipeflex.seeds.seed000.scenes:RIGID_EI",
    "SPRINKLER_EA": "pipeflex.seeds.seed000.scenes:SPRINKLER_EA",
    "cantilever_pipe": "pipeflex.seeds.seed000.scenes:cantilever_pipe",
    "coriolis_meter": "pipeflex.seeds.seed000.scenes:coriolis_meter",
    "simply_supported_pipe": "pipeflex.seeds.seed000.scenes:simply_supported_pipe",
    "sprinkler": "pipeflex.seeds.seed000.scenes:sprinkler",
    "SPIN_UP_BEAMS": "pipeflex.seeds.seed002.scenes:SPIN_UP_BEAMS",
    "rotating_cantilever": "pipeflex.seeds.seed002.scenes:rotating_cantilever",
    "spin_up_beam": "pipeflex.seeds.seed002.scenes:spin_up_beam",
    "PRINTER_POINTS": "pipeflex.seeds.seed004.scenes:PRINTER_POINTS",
    "concrete_printer": "pipeflex.seeds.seed004.scenes:concrete_printer",
    "ffrf_cantilever_pipe": "pipeflex.seeds.seed004.scenes:ffrf_cantilever_pipe",
    "ffrf_curved_pipe": "pipeflex.seeds.seed004.scenes:ffrf_curved_pipe",
    "beam_on_free_hub": "pipeflex.seeds.seed004.coupled_scenes:beam_on_free_hub",
    "sprinkler_on_hub": "pipeflex.seeds.seed004.coupled_scenes:sprinkler_on_hub",
}
__getattr__, __dir__ = _lazy.attach(__name__, _LAZY)

if TYPE_CHECKING:  # the lazy names, spelt out for editors and type checkers (tests/test_static_api.py)
    from .seeds.seed000.scenes import (RIGID_EI, SPRINKLER_EA, cantilever_pipe, coriolis_meter, simply_supported_pipe,
                                       sprinkler)
    from .seeds.seed002.scenes import SPIN_UP_BEAMS, rotating_cantilever, spin_up_beam
    from .seeds.seed004.coupled_scenes import beam_on_free_hub, sprinkler_on_hub
    from .seeds.seed004.scenes import PRINTER_POINTS, concrete_printer, ffrf_cantilever_pipe, ffrf_curved_pipe

__all__ = ["RIGID_EI", "SPRINKLER_EA", "cantilever_pipe", "coriolis_meter", "simply_supported_pipe", "sprinkler",
           "SPIN_UP_BEAMS", "rotating_cantilever", "spin_up_beam", "PRINTER_POINTS", "concrete_printer",
           "ffrf_cantilever_pipe", "ffrf_curved_pipe", "sprinkler_on_hub", "beam_on_free_hub"]
