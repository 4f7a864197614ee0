"""The one progress policy of pipeflex's long loops, and the package's logger.

Every loop that reports progress (:func:`pipeflex.simulate`, :func:`pipeflex.sweep`, and
what runs on them) takes ``progress``:

- ``None`` (the policy): in a Jupyter kernel, a progress bar (a widget if ipywidgets is
  installed, else a text bar on stderr); on a terminal (stderr a TTY), a text bar on
  stderr; either only once the loop has run :data:`BAR_DELAY` seconds of wall time (a
  short run draws nothing). Elsewhere (a log file, CI): an INFO line on the logger
  ``"pipeflex"`` every :data:`LOG_INTERVAL` seconds of wall time, no ``\\r`` updates.
  tqdm draws the bars; without it the lines are written instead.
- ``True``: as ``None`` but the bar shows from the start; the lines go to stderr unless
  logging is set up to show the logger's INFO messages.
- ``False``: nothing (tqdm is not imported).

Log messages (milestones of the long analyses at INFO and DEBUG) go to
``logging.getLogger("pipeflex")``, which has a ``NullHandler`` (the library convention:
the application decides what is shown, e.g. ``logging.basicConfig(level=logging.INFO)``).
"""
from __future__ import annotations

import importlib.util
import logging
import math
import sys
import time
from typing import Optional

#: The package's logger (the analyses log to it or to its children).
logger = logging.getLogger("pipeflex")
logger.addHandler(logging.NullHandler())

#: Wall time [s] a loop runs before the policy (``progress=None``) shows a bar.
BAR_DELAY = 3.0
#: Wall time [s] between two progress lines where no bar is drawn.
LOG_INTERVAL = 15.0


def in_notebook() -> bool:
    """True in a Jupyter (IPython) kernel. Does not import IPython."""
    ipython = sys.modules.get("IPython")
    if ipython is None:
        return False
    try:
        shell = ipython.get_ipython()
    except Exception:  # noqa: BLE001 -- a half-initialised IPython is not a kernel
        return False
    return shell is not None and getattr(shell, "kernel", None) is not None


def _has_widgets() -> bool:
    """ipywidgets is installed (tqdm's notebook bar needs it; without it tqdm.auto warns
    "IProgress not found")."""
    return importlib.util.find_spec("ipywidgets") is not None


def _stderr_is_tty() -> bool:
    isatty = getattr(sys.stderr, "isatty", None)
    try:
        return bool(isatty and isatty())
    except ValueError:  # a closed stream
        return False


def _logging_shows(level: int) -> bool:
    """Whether a message of ``level`` on :data:`logger` reaches a handler other than a
    NullHandler (else a forced progress line goes to stderr)."""
    if not logger.isEnabledFor(level):
        return False
    node = logger
    while node is not None:
        if any(not isinstance(h, logging.NullHandler) and level >= h.level for h in node.handlers):
            return True
        if not node.propagate:
            return False
        node = node.parent
    return False


def mode(progress: Optional[bool]) -> str:
    """``"off"``, ``"bar"`` (a notebook or a terminal) or ``"lines"`` (elsewhere)."""
    if progress is not None and not progress:
        return "off"
    return "bar" if in_notebook() or _stderr_is_tty() else "lines"


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}" if seconds >= 3600 \
        else f"{seconds // 60}:{seconds % 60:02d}"


class Progress:
    """Progress of one loop over ``total`` (simulated seconds, points, ...) under the policy.

    Use as a context manager; :meth:`update` sets the amount done, :meth:`advance` adds
    to it, :meth:`note` shows extra fields (e.g. ``failed=2``).

    Args:
        progress: None (the policy), True (forced) or False (off); see the module.
        total: the amount of the whole loop, in ``unit``.
        desc: what runs, e.g. ``"simulate (generalized_alpha)"``.
        unit: ``"s"`` (simulated time: shown rounded, as a percentage) or a count's unit.
        initial: the amount already done.
        leave: keep the bar on screen when done.
    """

    def __init__(self, progress: Optional[bool], total: float, *, desc: str, unit: str, initial: float = 0,
                 leave: bool = True):
        self.total, self.done = total, initial  # ints stay ints: a count shows as 3/3
        self.desc, self.unit, self.leave = desc, unit, leave
        self.forced = progress is True
        self.mode = mode(progress)
        self.fields: dict = {}
        self._initial = self.done
        self._start = self._last_line = time.monotonic()
        self._bar = None
        # decimals of the amount shown: 4 significant digits of the total
        self._digits = max(0, 3 - math.floor(math.log10(self.total))) if self.total > 0 else 0
        if self.mode == "bar" and self.forced:
            self._open_bar()

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def advance(self, amount: float = 1) -> None:
        self.update(self.done + amount)

    def update(self, done: float) -> None:
        """The amount done so far is ``done`` (absolute, in ``unit``)."""
        self.done = done
        if self.mode == "off":
            return
        now = time.monotonic()
        if self.mode == "bar":
            if self._bar is None and now - self._start >= BAR_DELAY:
                self._open_bar()
            if self._bar is not None:
                # absolute and rounded: a sum of steps is not a round number (0.30000000000000004)
                self._bar.n = round(self.done, self._digits)
                self._bar.update(0)
                return
        if self.mode == "lines" and now - self._last_line >= LOG_INTERVAL:
            self._last_line = now
            self._line(now)

    def note(self, **fields) -> None:
        """Extra fields shown with the progress (e.g. ``failed=2``)."""
        self.fields.update(fields)
        if self._bar is not None:
            self._bar.set_postfix(self.fields, refresh=False)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def _open_bar(self) -> None:
        try:
            if in_notebook() and _has_widgets():
                from tqdm.notebook import tqdm
            else:  # tqdm.std: a text bar (tqdm.auto would warn "IProgress not found" without ipywidgets)
                from tqdm.std import tqdm
        except ImportError:
            self.mode = "lines"
            return
        # simulated time as a percentage and rounded values (the sum of the steps is
        # not a round number); counts as tqdm shows them
        fmt = ("{desc}: {percentage:3.0f}%|{bar}| t = {n:.4g}/{total:.4g} s [{elapsed}<{remaining}{postfix}]"
               if self.unit == "s" else None)
        self._bar = tqdm(total=self.total, initial=round(self.done, self._digits), desc=self.desc, unit=self.unit,
                         leave=self.leave, file=sys.stderr, bar_format=fmt, dynamic_ncols=True)
        self._bar.start_t -= time.monotonic() - self._start  # elapsed from the loop's start, not the bar's
        if self.fields:
            self._bar.set_postfix(self.fields, refresh=False)

    def _line(self, now: float) -> None:
        elapsed = now - self._start
        frac = self.done / self.total if self.total > 0 else 1.0
        rate = (self.done - self._initial) / elapsed if elapsed > 0 else 0.0
        left = f", ~{_duration((self.total - self.done) / rate)} left" if rate > 0 else ""
        amount = (f"t = {self.done:.4g}/{self.total:.4g} s" if self.unit == "s"
                  else f"{self.done:.0f}/{self.total:.0f} {self.unit}")
        extra = "".join(f", {k} {v}" for k, v in self.fields.items())
        message = f"{self.desc}: {amount} ({100 * frac:.0f}%){extra}, {_duration(elapsed)} elapsed{left}"
        if self.forced and not _logging_shows(logging.INFO):
            print(message, file=sys.stderr, flush=True)
        else:
            logger.info("%s", message)
