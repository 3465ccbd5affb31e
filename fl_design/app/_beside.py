"""A stage run in a child process beside the main job's later stages (the certify stage).

Why a process and not a thread: CasADi's symbolic objects (``SX``, ``MX``, ``DM`` and their
sparsity patterns) are reference counted without atomics, and its Python binding releases the
GIL, so building or evaluating CasADi expressions in two threads at once corrupts memory
(casadi/casadi#3518: "creating DM, SX or MX is not thread safe"). The certify stage builds the
loop's Jacobians with CasADi while simulate and codegen build their kernels in the main thread;
run in a thread beside them, it crashed a whole ``fl-design run`` with SIGSEGV about once in
a few thousand runs. A fresh interpreter shares nothing with the main one.

The child is ``python -c "from fl_design.app._beside import child; child()"``, started with this
process's ``sys.path`` (it imports the same fl_design) and environment (the same cache folder,
ISA and thread settings). The parent sends two pickled frames through the child's stdin (its
``sys.path``, then the target and its arguments); the child answers through a private copy of
its stdout (its own stdout goes to stderr, so a stray print cannot corrupt the frames): progress
lines, then the result or the exception. The bytes go only between this process and its own
child through pipes, never to or from a file. A child that dies (a signal, an exit) is a
:class:`~fl_design.errors.WorkerLostError` naming its exit status; a child still running after
:data:`HARD_LIMIT_S` seconds is killed and reported the same way (never a hang); a child whose
parent died exits within a second.

Examples
--------
>>> from fl_design.app._beside import Beside
>>> job = Beside("demo", "1/1", "fl_design.app._beside:echo", (21,), say=None)
>>> job.wait()
(42, False)
"""

from __future__ import annotations

import importlib
import os
import pickle
import struct
import subprocess
import sys
import threading
import time

from .._pickle import dumps

#: Seconds after which a child still running is killed (the certify stage stops starting new
#: searches after its own budget, :data:`fl_design.app._stages.CERTIFY_BUDGET_S`; this is the
#: bound on one search that would not end).
HARD_LIMIT_S = 900.0
#: The stages of the main job run this way, and the function each child calls.
TARGETS = {"certify": "fl_design.app._beside:certify_stage"}
#: Modules the child imports before it receives its work (it is started at the job's start,
#: its work is sent once derive is done: the imports overlap the derive stage).
WARM = ("fl_design.app._stages", "fl_design.analysis", "cvxpy")
_HEADER = struct.Struct(">Q")


def echo(x, progress=None):
    """A target for the examples: ``(2 * x, False)`` (a result, not read from a cache)."""
    if progress is not None:
        progress(f"doubling {x}")
    return 2 * x, False


def certify_stage(setup, derivation: dict, quick: bool, progress=None) -> tuple[dict, bool]:
    """The main job's certify stage through its signed cache: ``(results, from_cache)``.

    Parameters
    ----------
    setup : fl_design.app._build.Setup
    derivation : dict
        The derive stage's results.
    quick : bool
    progress : callable, optional
        ``progress(line)`` for each step.

    Returns
    -------
    (dict, bool)

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._beside import certify_stage
    >>> from fl_design.app._build import build_setup
    >>> from fl_design.app._stages import derive
    >>> s = build_setup(load_config(None))
    >>> sorted(certify_stage(s, derive(s), True)[0])[:3]
    ['curve', 'eps', 'gamma']
    """
    from . import _stages
    from ._stage_cache import cached_stage

    return cached_stage(setup, "certify", quick,
                        lambda: _stages.certify(setup, derivation, quick, progress=progress))


def _start_process(env: dict) -> subprocess.Popen:
    """The child: this Python running :func:`child`, its stdin and stdout piped to us."""
    if not sys.executable:
        raise OSError("no Python executable to start (sys.executable is empty)")
    return subprocess.Popen(
        [sys.executable, "-c", "from fl_design.app._beside import child; child()"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env)


def _target(spec: str):
    module, name = spec.split(":")
    return getattr(importlib.import_module(module), name)


def _write(stream, message) -> None:
    try:
        blob = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as err:  # noqa: BLE001 - an unpicklable exception: its words instead
        from ..errors import ComputationError

        blob = pickle.dumps(("error", ComputationError(
            f"{type(message[-1]).__name__}: {message[-1]} (not picklable: {err})")))
    stream.write(_HEADER.pack(len(blob)) + blob)
    stream.flush()


def _read(stream):
    head = stream.read(_HEADER.size)
    if len(head) < _HEADER.size:
        return None
    (n,) = _HEADER.unpack(head)
    blob = stream.read(n)
    return pickle.loads(blob) if len(blob) == n else None  # our own child's bytes, a pipe


def _watch_parent(parent: int) -> None:  # pragma: no cover (child)
    while True:
        time.sleep(1.0)
        if os.getppid() != parent:
            os._exit(70)  # the parent died: nobody reads the answer


def child() -> None:  # pragma: no cover (runs in the child process)
    """The child process's entry: read the frames from stdin, answer on stdout."""
    out = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # a stray print goes to stderr, never into the frames
    sys.stdout = sys.stderr
    inp = sys.stdin.buffer
    sys.path[:] = _read(inp)  # a list of str: unpickled without importing anything
    for module in WARM:  # imported while the parent still runs its stages (started early)
        importlib.import_module(module)
    task = _read(inp)
    if task is None:  # the parent stopped before sending any work
        return
    spec, args, parent = task
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()
    lock = threading.Lock()

    def progress(line: str) -> None:
        with lock:
            _write(out, ("line", str(line)))

    start, cpu = time.perf_counter(), time.process_time()
    try:
        value = _target(spec)(*args, progress=progress)
    except BaseException as exc:  # noqa: BLE001 - handed to the parent, raised there
        with lock:
            _write(out, ("error", exc))
        return
    with lock:
        _write(out, ("done", value, time.perf_counter() - start, time.process_time() - cpu))


class Beside:
    """One stage computed in a child process while the caller goes on (module docstring).

    Parameters
    ----------
    stage, label : str
        The stage's name and its ``k/n`` label (progress lines).
    spec : str, optional
        ``"module:function"``: the child calls ``function(*args, progress=line_callback)``.
        None: the child is started (and imports :data:`WARM`) but waits for :meth:`submit`.
    args : tuple
        Picklable arguments.
    say : callable or None
        ``say(line)`` for each of the child's progress lines (called in a reader thread).

    Raises
    ------
    pickle.PicklingError, TypeError, AttributeError
        ``args`` cannot be sent to a process (the caller runs the stage in turn instead).
    OSError
        No child process could be started.

    Notes
    -----
    Start the child early (``spec=None``) and :meth:`submit` the work later: the child's
    imports (about a second) then overlap what the caller does meanwhile.

    Examples
    --------
    >>> from fl_design.app._beside import Beside
    >>> Beside("demo", "1/1", "fl_design.app._beside:echo", ("ab",), say=None).wait()
    ('abab', False)
    """

    def __init__(self, stage: str, label: str, spec: str | None = None, args: tuple = (), *,
                 say=None):
        self.stage, self.label, self.say = stage, label, say
        self.value = self.error = self.thread = None
        self.answered = False  # the child sent its result or its exception
        self.wall = self.cpu = 0.0
        import fl_design

        env = dict(os.environ)
        root = os.path.dirname(os.path.dirname(os.path.abspath(fl_design.__file__)))
        env["PYTHONPATH"] = os.pathsep.join([root] + ([env["PYTHONPATH"]]
                                                      if env.get("PYTHONPATH") else []))
        self.proc = _start_process(env)
        self.started = time.perf_counter()
        try:
            _write(self.proc.stdin, [p for p in sys.path if isinstance(p, str)])
        except OSError:
            pass  # the child died at once: its exit status is read when it is waited for
        if spec is not None:
            self.submit(spec, args)

    def submit(self, spec: str, args: tuple) -> None:
        """Send the work: the child calls ``spec``'s function with ``args``.

        Raises
        ------
        pickle.PicklingError, TypeError, AttributeError
            ``args`` cannot be sent (the child is ended; the caller runs the stage itself).
        OSError
            The child has already exited (it could not start: e.g. a frozen application
            whose executable is not a Python); the caller runs the stage itself.
        """
        code = self.proc.poll()
        if code is not None:
            raise OSError(f"the {self.stage} stage's process exited (status {code}) before "
                          "its work was sent")
        try:
            payload = dumps((spec, args, os.getpid()))
        except Exception:
            self.close()
            raise
        self.started = time.perf_counter()
        self.thread = threading.Thread(target=self._talk, args=(payload,),
                                       name=f"fl-design-{self.stage}", daemon=True)
        self.thread.start()

    def _talk(self, payload: bytes) -> None:
        try:
            self.proc.stdin.write(_HEADER.pack(len(payload)) + payload)
            self.proc.stdin.close()
            while True:
                message = _read(self.proc.stdout)
                if message is None:
                    break
                if message[0] == "line":
                    if self.say is not None:
                        self.say(message[1])
                elif message[0] == "error":
                    self.error, self.answered = message[1], True
                else:
                    _, self.value, self.wall, self.cpu = message
                    self.answered = True
        except (OSError, ValueError, pickle.UnpicklingError, EOFError):
            pass  # the child died mid-frame: its exit status says how (below)
        self.proc.wait()
        if not self.answered:
            from ..errors import WorkerLostError

            code = self.proc.returncode
            how = f"signal {-code}" if code < 0 else f"exit code {code}"
            self.error = WorkerLostError(
                f"the {self.stage} stage's process (pid {self.proc.pid}) died ({how}) before "
                "it answered (what it printed, if anything, is above on stderr); run the job again")

    def done(self) -> bool:
        """True once the child has answered (or died); False before :meth:`submit`."""
        return self.thread is not None and not self.thread.is_alive()

    def raise_error(self) -> None:
        """Re-raise the stage's exception, if the child has ended with one."""
        if self.error is not None and self.done():
            raise self.error

    def wait(self, limit: float = HARD_LIMIT_S):
        """Wait for the child (one-second waits: interruptible), re-raise its error.

        Returns
        -------
        object
            What the target returned.

        Raises
        ------
        WorkerLostError
            The child died, or ran over ``limit`` seconds (then it is killed).
        """
        if self.thread is None:
            raise RuntimeError("Beside.wait before submit: no work was sent")
        while self.thread.is_alive():
            self.thread.join(timeout=1.0)
            if self.thread.is_alive() and time.perf_counter() - self.started > limit:
                self.close()
                self.thread.join(timeout=10.0)
                from ..errors import WorkerLostError

                raise WorkerLostError(f"the {self.stage} stage ran over {limit:.0f} s; its "
                                      "process was killed (no result)")
        self.raise_error()
        return self.value

    def close(self) -> None:
        """Kill the child if it still runs (the caller stopped: an error, Ctrl-C)."""
        if self.thread is None and self.proc.stdin is not None and not self.proc.stdin.closed:
            try:
                self.proc.stdin.close()  # no work will come
            except OSError:
                pass
        if self.proc.poll() is None:
            self.proc.kill()
            try:
                self.proc.wait(timeout=10.0)
            except subprocess.TimeoutExpired:  # pragma: no cover - a zombie we cannot reap
                pass


__all__ = ["HARD_LIMIT_S", "TARGETS", "WARM", "Beside", "certify_stage", "child", "echo"]
