"""What a long library call is doing and how far it is: silent while it is quick.

The library's long calls (:func:`fl_design.tune`, :func:`fl_design.eps_star_curve`) take a
``progress`` argument: ``True`` prints a line per step on stderr at once, ``False`` never, and
the default ``"auto"`` starts printing once the call has run :data:`DELAY` seconds (its first line
says the step it is in), so a quick call stays quiet and a long one says what it does. Lines go
to ``sys.stderr`` as it is when they are printed, so a notebook shows them under the cell.

Examples
--------
>>> import io, sys
>>> from fl_design._progress import Lines
>>> buf, old = io.StringIO(), sys.stderr
>>> sys.stderr = buf
>>> say = Lines("fl.demo", progress=True)
>>> say("step 1/2: scanning")
>>> quiet = Lines("fl.demo", progress="auto")  # within its first 2 s: nothing
>>> quiet("step 1/2: scanning")
>>> sys.stderr = old
>>> buf.getvalue().startswith("[fl.demo] step 1/2: scanning (0.0 s")
True
>>> buf.getvalue().count("\\n")
1
"""

from __future__ import annotations

import sys
import time

from .errors import ParameterError

#: Seconds a call runs before ``progress="auto"`` starts showing its steps.
DELAY = 2.0

#: The values a ``progress`` argument takes.
CHOICES = (True, False, "auto")


def check(progress) -> bool | str:
    """``progress`` validated (``True``, ``False`` or ``"auto"``).

    Examples
    --------
    >>> from fl_design._progress import check
    >>> check("auto"), check(False)
    ('auto', False)
    """
    if progress is True or progress is False or progress == "auto":
        return progress
    raise ParameterError(f"progress={progress!r} is not valid: True (a line per step), False "
                         "(none) or 'auto' (lines once the call has run 2 s)")


class Lines:
    """A callable printing ``[prefix] text (seconds so far)`` on stderr, as ``progress`` says.

    Parameters
    ----------
    prefix : str
        The call's name, e.g. ``"fl.tune"``.
    progress : bool or str, optional
        ``True``, ``False`` or ``"auto"`` (default): lines from :data:`DELAY` seconds on.
    delay : float, optional
        The seconds of ``"auto"``.

    Examples
    --------
    >>> from fl_design._progress import Lines
    >>> Lines("fl.demo", progress=False)("never shown")
    """

    def __init__(self, prefix: str, progress="auto", delay: float = DELAY):
        self.mode = check(progress)
        self.prefix, self.delay, self.t0 = prefix, float(delay), time.perf_counter()

    @property
    def enabled(self) -> bool:
        """Whether a line printed now would be shown."""
        return self.mode is True or (self.mode == "auto"
                                     and time.perf_counter() - self.t0 >= self.delay)

    def __call__(self, text: str) -> None:
        if self.enabled:
            print(f"[{self.prefix}] {text} ({time.perf_counter() - self.t0:.1f} s)",
                  file=sys.stderr, flush=True)


__all__ = ["CHOICES", "DELAY", "Lines", "check"]
