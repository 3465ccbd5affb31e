"""A time budget for symbolic work: a derivation that runs too long stops with a clear error.

SymPy cannot be interrupted from outside, so the budget is a POSIX interval timer
(``SIGALRM``) armed around the work when it runs in the main thread; elsewhere (a worker thread,
Windows) the size bounds of the grammar (:func:`fl_design.symbolic._grammar.check_size`) are
the only guard. The budget is ``$FL_DESIGN_DERIVE_SECONDS`` (default :data:`DEFAULT_SECONDS`),
a finite positive number. A budget already running (nested) is left alone.

Examples
--------
>>> from fl_design.symbolic._budget import time_budget
>>> with time_budget("the example"):
...     x = sum(range(10))
>>> x
45
"""

from __future__ import annotations

import contextlib
import signal
import threading
import time

from .._limits import env_limit
from ..errors import DerivationTimeoutError

#: Default seconds allowed for one derivation (relative degree, normal form).
DEFAULT_SECONDS = 120.0
ENV = "FL_DESIGN_DERIVE_SECONDS"
_ACTIVE = threading.local()


@contextlib.contextmanager
def time_budget(what: str, seconds: float | None = None):
    """Run the body with at most ``seconds`` of wall time (main thread, POSIX), else raise.

    Parameters
    ----------
    what : str
        What is computed, for the message (``"the relative degree of plant 'p'"``).
    seconds : float, optional
        Default ``$FL_DESIGN_DERIVE_SECONDS`` or :data:`DEFAULT_SECONDS`.

    Raises
    ------
    DerivationTimeoutError
        The body ran longer (a :class:`~fl_design.errors.ComputationError`).

    Examples
    --------
    >>> import time
    >>> from fl_design.errors import DerivationTimeoutError
    >>> from fl_design.symbolic._budget import time_budget
    >>> try:
    ...     with time_budget("a nap", seconds=0.05):
    ...         time.sleep(1)
    ... except DerivationTimeoutError as exc:
    ...     print(str(exc)[:40])
    a nap took longer than its budget of 0.0
    """
    if seconds is None:
        seconds = float(env_limit(ENV, DEFAULT_SECONDS, unit="seconds", integer=False))
    usable = (hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()
              and not getattr(_ACTIVE, "on", False))
    if not usable:
        yield
        return
    outer = signal.getitimer(signal.ITIMER_REAL)[0]  # a timer already armed (pytest-timeout)
    ours_first = outer == 0 or seconds <= outer
    start = time.monotonic()

    def expired(signum, frame):
        if ours_first:
            raise DerivationTimeoutError(
                f"{what} took longer than its budget of {seconds:g} s and was stopped; simplify "
                f"the expressions (fewer terms, lower powers) or raise ${ENV}")
        if callable(previous):  # the outer timer's turn
            previous(signum, frame)

    previous = signal.signal(signal.SIGALRM, expired)
    _ACTIVE.on = True
    signal.setitimer(signal.ITIMER_REAL, seconds if ours_first else outer)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        _ACTIVE.on = False
        if outer > 0:
            signal.setitimer(signal.ITIMER_REAL, max(1e-3, outer - (time.monotonic() - start)))


__all__ = ["DEFAULT_SECONDS", "ENV", "time_budget"]
