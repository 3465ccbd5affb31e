"""Bounded waits on other machines: a call with a deadline, and connecting to a Dask scheduler.

Every wait of fl_design on something outside this process has a timeout and says what it
waited for: :func:`bounded_call` runs a call in a daemon thread and gives up after its
deadline; :func:`connect_scheduler` connects to a Dask scheduler and requires its first answer
within :data:`CONNECT_SECONDS` (a server that accepts and never answers is refused, never
waited on). Re-exported by :mod:`fl_design.sim._executor`.

Examples
--------
>>> from fl_design.sim._scheduler import bounded_call
>>> bounded_call(lambda: "ok", 1.0, "a quick call")
'ok'
"""

from __future__ import annotations

import threading


def bounded_call(fn, seconds: float, what: str):
    """``fn()`` run in a daemon thread, waited for at most ``seconds``.

    Returns ``fn()``'s value; re-raises its exception; raises :class:`TimeoutError` naming
    ``what`` when it has not answered in time (the thread is abandoned).

    Examples
    --------
    >>> from fl_design.sim._scheduler import bounded_call
    >>> bounded_call(lambda: 42, 1.0, "the answer")
    42
    """
    box: dict = {}
    done = threading.Event()

    def call():
        try:
            box["value"] = fn()
        except BaseException as exc:  # noqa: BLE001 - handed to the waiting thread
            box["error"] = exc
        finally:
            done.set()

    threading.Thread(target=call, name=f"fl_design: {what}", daemon=True).start()
    if not done.wait(seconds):
        raise TimeoutError(f"{what} did not answer within {seconds:g} s")
    if "error" in box:
        raise box["error"]
    return box.get("value")


#: Seconds allowed to connect to a Dask scheduler and get its first answer.
CONNECT_SECONDS = 10.0
_SCHEMES = ("tcp", "tls", "ws", "wss", "inproc", "ucx")


def connect_scheduler(address: str, *, timeout: float = CONNECT_SECONDS):
    """A ``distributed.Client`` of the scheduler at ``address``, connected and answering
    within ``timeout`` seconds, else a clear error (never a hang, never a raw traceback).

    A server that accepts the connection but never answers (not a Dask scheduler, or frozen)
    is refused after ``timeout`` seconds; ``tls://`` without certificates is refused with
    what to configure.

    Parameters
    ----------
    address : str
        ``tcp://host:port`` (or ``host:port``), ``tls://...``, ``ws://...``...
    timeout : float, optional
        Seconds for the connection and the scheduler's first answer.

    Returns
    -------
    distributed.Client

    Raises
    ------
    ParameterError
        Not an address, an unknown scheme, refused, silent, or misconfigured TLS.
    MissingDependencyError
        ``dask.distributed`` is not installed.

    Examples
    --------
    >>> from fl_design.sim._scheduler import connect_scheduler
    >>> connect_scheduler("gopher://example:8786")
    Traceback (most recent call last):
    ...
    fl_design.errors.ParameterError: the Dask scheduler address 'gopher://example:8786' has the scheme 'gopher'; ...
    """
    from ..errors import MissingDependencyError, ParameterError

    if not isinstance(address, str) or not address.strip():
        raise ParameterError(f"the Dask scheduler address must be a non-empty string such as "
                             f"tcp://host:8786, got {address!r}")
    scheme = address.split("://", 1)[0].lower() if "://" in address else "tcp"
    if scheme not in _SCHEMES:
        raise ParameterError(f"the Dask scheduler address {address!r} has the scheme {scheme!r}; "
                             f"valid: {', '.join(s + '://' for s in _SCHEMES)}")
    try:
        from distributed import Client
    except ImportError:
        raise MissingDependencyError("a Dask scheduler needs dask.distributed: pip install "
                                     "'fl_design[dask]'") from None
    abandoned = threading.Event()

    def connect():
        client = Client(address, timeout=f"{timeout:g}s")
        try:
            client.scheduler_info()  # its first answer
        except BaseException:
            client.close()
            raise
        if abandoned.is_set():
            client.close()
        return client

    try:
        return bounded_call(connect, timeout + 2.0, f"the Dask scheduler {address!r}")
    except TimeoutError:
        abandoned.set()
        raise ParameterError(
            f"cannot connect to the Dask scheduler {address!r}: no answer within {timeout:g} s "
            "(something accepts connections there but does not answer as a Dask scheduler, or "
            "it is frozen); check the address and that `dask scheduler` runs there") from None
    except Exception as err:  # noqa: BLE001 - whatever distributed raises: one clear line
        first = (str(err).splitlines() or [""])[0][:300] or type(err).__name__
        hint = ("; a tls:// scheduler needs certificates: configure "
                "distributed.comm.tls (ca-file, client cert and key) in the Dask config"
                if scheme in ("tls", "wss") else "")
        raise ParameterError(f"cannot connect to the Dask scheduler {address!r}: "
                             f"{type(err).__name__}: {first}{hint}") from None


__all__ = ["CONNECT_SECONDS", "bounded_call", "connect_scheduler"]
