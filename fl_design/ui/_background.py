"""The tuner's slow results, computed in one background process and shown when ready.

The stability map (a sweep over the config's eps and gamma ranges, the design point on it and
the map's empirical ``eps*``), the certificates (the gamma interval, the ``eps*`` bracket of the
class, the certified ``eps*`` curve against gamma), the margins at the plant input and the C
step's cost take from a second to a minute each. :class:`Background` runs them in a child
process (``spawn``: no fork of a process holding CasADi and server threads), in its own process
group, cheapest first, and posts each result as soon as it is ready. Each stage is keyed by the
controls it depends on (:func:`stage_keys`): a result stays valid while its key does; when the
controls move, the process is paused at once (SIGSTOP to its group: the page's redraws get
the cores); once they have been still for :data:`QUIET_S` seconds it resumes if it still
computes what is needed, else it is ended (its whole group: the sweep's pool and compilers
too) and a new one starts. A stage's failure is a value (its message), never a crash.

Examples
--------
>>> from fl_design.ui._background import stage_keys
>>> keys = stage_keys({"eps": 0.05, "gamma": 3e-4, "gains": [2.0, 4.0], "T": 1e-3,
...                    "reference": 0.3, "noise_std": 0.0, "u_min": -2.5, "u_max": 2.5,
...                    "duration": 20.0})
>>> keys["cost"] == stage_keys({"eps": 0.1, "gamma": 1e-3, "gains": [2.0, 4.0], "T": 1e-3,
...     "reference": 0.3, "noise_std": 0.0, "u_min": -2.5, "u_max": 2.5, "duration": 20.0})["cost"]
True
"""

from __future__ import annotations

import json
import math
import multiprocessing
import os
import pickle
import signal
import tempfile
import threading
import time

from .._pickle import dumps

#: Stages, cheapest first, and the controls each depends on.
STAGES = {
    "margins": ("eps", "gamma", "gains", "T"),
    "gamma": ("eps", "gamma", "gains", "T"),
    "cost": ("limited",),
    "map": ("gains", "T", "reference", "u_min", "u_max", "duration"),
    "curve": ("gains", "T"),
    "eps": ("eps", "gamma", "gains", "T"),
}
#: Seconds the controls must stay still before a new background process starts.
QUIET_S = 0.6
#: Most grid points per axis of the tuner's stability map.
MAP_POINTS = 12
#: Gains on the certified curve.
CURVE_POINTS = 6
#: Steps of the C step's timing run.
BENCH_STEPS = 200_000


def stage_keys(values: dict) -> dict:
    """Each stage's key: the JSON of the controls it depends on.

    Parameters
    ----------
    values : dict
        Checked controls (:meth:`fl_design.ui._model.Tuner.check`).

    Returns
    -------
    dict
        Stage -> str.
    """
    v = dict(values) | {"limited": values.get("u_min") is not None}
    return {s: json.dumps([v[k] for k in keys]) for s, keys in STAGES.items()}


def _words(tuner, v, covers: str, cert=None) -> str:
    described = getattr(cert, "class_description", "")
    if described:  # the certificate names the class it certified
        unc = "; ".join(getattr(cert, "uncovered", ()) or ())
        return f"{described}" + (f"; not covered: {unc}" if unc else "") + f" ({covers} b)"
    cls = tuner.plant_class
    if cls is None:
        return class_words(tuner.b_bounds, tuner.rho, v["T"], covers)
    return f"{cls.describe()}; not covered: {', '.join(cls.uncovered())} ({covers} b)"


def class_words(b_bounds, rho: int, T: float, covers: str) -> str:
    """The class a certificate covers, in words.

    Parameters
    ----------
    b_bounds : (float, float)
        The b range.
    rho : int
        Relative degree.
    T : float
        Sampling time (s).
    covers : str
        ``"frozen"``, ``"varying"`` or ``"rate-bounded"``.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.ui._background import class_words
    >>> class_words((3.6, 6.8), 2, 1e-3, "varying").split(" (")[0]
    'every plant of relative degree 2 sampled at T = 0.001 s whose b may vary in time, anywhere in [3.6, 6.8]'
    """
    how = {"frozen": "b is any constant in", "varying": "b may vary in time, anywhere in",
           "rate-bounded": "b varies at a bounded rate in"}.get(covers, f"b ({covers}) in")
    return (f"every plant of relative degree {rho} sampled at T = {T:g} s whose {how} "
            f"[{b_bounds[0]:.4g}, {b_bounds[1]:.4g}] (the chain of integrators plus b u, "
            "linear surrogate); not covered: measurement noise, input limits, the estimate "
            "clamp, windup, input delay")


def _num(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


# --- the stages (run in the child process) -----------------------------------------------------
def _margins(tuner, design, v):
    from ..analysis import loop_margins

    out = []
    for b in tuner.b_bounds:
        m = loop_margins(design, b)
        out.append({"b": b, "text": m._repr_lines()[0]})
    return {"rows": out, "words": "at the plant input, b frozen at each end of its range "
            "(linear surrogate loop)"}


def _gamma(tuner, design, v):
    from ..analysis import certify_gamma

    c = certify_gamma(design, tuner.cert_target)
    return {"text": str(c), "words": _words(tuner, v, "varying", c)}


def _cost(tuner, design, v):
    from ..codegen import generate_c

    with tempfile.TemporaryDirectory(prefix="fl-design-ui-cost-") as tmp:
        pkg = generate_c(design, os.path.join(tmp, "c"))
        c = pkg.cost(bench_steps=BENCH_STEPS)
        d = c.to_dict()
    return {"text": _cost_text(d), "row": d}


def _cost_text(d: dict) -> str:
    return (f"C step ({d['precision']}): {d['ns_per_step']:.0f} ns per step on this machine, "
            f"{d['flops']} operations, stack {d['stack_bytes']} B, code {d['code_bytes']} B, "
            f"state {d['state_bytes']} B (the numbers of eps, gamma and the gains do not change "
            "it)")


def _map(tuner, design, v):
    import numpy as np

    from ..sim import sweep

    cfg = tuner.config.sweep
    n = min(cfg.points, MAP_POINTS)
    sign = math.copysign(1.0, v["gamma"])
    g_lo, g_hi = sorted(abs(x) for x in cfg.gamma)
    eps, gamma = np.geomspace(*cfg.eps, n), sign * np.geomspace(g_lo, g_hi, n)
    scenario = tuner.scenario_for(v | {"noise_std": 0.0})
    m = sweep(tuner.plant, design, scenario, eps=eps, gamma=gamma,
              classifier=tuner.classifier, progress=False)
    stars = [m.eps_star(float(g)) for g in m.gamma]
    from ..sim import Status

    return {"eps": [float(e) for e in m.eps], "gamma": [abs(float(g)) for g in m.gamma],
            "status": np.asarray(m.status, dtype=int).tolist(),
            "labels": {int(s): s.label for s in Status},
            "eps_star": [{"lower": _num(s.lower), "upper": _num(s.upper), "text": str(s)}
                         for s in stars], "duration": float(m.duration)}


def _curve(tuner, design, v):
    import numpy as np

    from ..analysis import eps_star_curve

    cfg = tuner.config.certify
    lo, hi = sorted(abs(x) for x in (cfg.gamma or tuner.config.sweep.gamma))
    c = eps_star_curve(design, tuner.cert_target, np.geomspace(lo, hi, CURVE_POINTS),
                       eps_range=tuple(cfg.eps_range or tuner.config.sweep.eps))
    return {"gamma": [float(g) for g in c.gamma],
            "frozen": [_num(x) for x in c.eps_star_frozen],
            "certified": [_num(x) for x in c.eps_star_certified], "covers": c.covers,
            "words": _words(tuner, v, c.covers, c)}


def _eps(tuner, design, v):
    from ..analysis import certify_eps

    cfg = tuner.config
    c = certify_eps(design, tuner.cert_target,
                    eps_range=tuple(cfg.certify.eps_range or cfg.sweep.eps))
    brackets = [{"covers": b.covers, "certified": _num(b.certified), "refuted": _num(b.refuted),
                 "words": _words(tuner, v, b.covers, c)}
                for b in c.brackets]
    return {"text": str(c), "certified": bool(c.certified), "covers": c.covers,
            "eps_star_certified": _num(c.eps_star_certified), "brackets": brackets,
            "words": _words(tuner, v, c.covers, c)}


_RUN = {"margins": _margins, "gamma": _gamma, "cost": _cost, "map": _map, "curve": _curve,
        "eps": _eps}


def _work(blob: bytes, values: dict, todo: list, conn) -> None:  # pragma: no cover (child)
    """The child process: each stage of ``todo`` in turn, each result sent when ready."""
    os.setsid()  # its own group: ended whole (sweep pools, compilers) when the controls move
    setup = pickle.loads(blob)  # our own parent's bytes (dumps), through a pipe
    import warnings

    warnings.simplefilter("ignore")
    from ..errors import FlDesignError
    from ._model import Tuner

    try:
        tuner = Tuner(setup)
        design = tuner.design_for(values)
    except FlDesignError as err:
        for stage, key in todo:
            conn.send((stage, key, {"error": str(err)}, 0.0))
        return
    for stage, key in todo:
        start = time.perf_counter()
        if tuner.b_bounds is None and stage in ("margins", "gamma", "curve", "eps"):
            data = {"error": "the plant declares no region and input range (or b changes sign "
                    "on them): no b range to certify"}
        else:
            try:
                data = _RUN[stage](tuner, design, values)
            except FlDesignError as err:
                data = {"error": str(err)}
            except Exception as err:  # noqa: BLE001 (a stage's failure is shown, never a crash)
                data = {"error": f"{type(err).__name__}: {err}"}
        conn.send((stage, key, data, time.perf_counter() - start))
    conn.close()


def _end(proc, paused: bool) -> None:
    """End a background process and its whole group (a paused one is resumed to end)."""
    if proc is None or not proc.is_alive():
        return
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        if paused:
            os.killpg(proc.pid, signal.SIGCONT)
    except (ProcessLookupError, PermissionError):  # before its setsid: the process alone
        proc.terminate()
        if paused:
            try:
                os.kill(proc.pid, signal.SIGCONT)
            except ProcessLookupError:
                pass
    proc.join(timeout=5)
    if proc.is_alive():
        proc.kill()
        proc.join(timeout=5)


class Background:
    """The slow results of the current controls (module docstring).

    Parameters
    ----------
    setup : fl_design.ui.TunerSetup
        The tuner's setup (pickled to the child process).
    enabled : bool, optional
        False: nothing is computed (tests of the page alone).

    Examples
    --------
    >>> from fl_design.app._cli import ui_setup
    >>> from fl_design.ui._background import Background
    >>> bg = Background(ui_setup(), enabled=False)
    >>> bg.snapshot()["map"]["state"]
    'waiting'
    >>> bg.close()
    """

    def __init__(self, setup, *, enabled: bool = True) -> None:
        self.setup, self.enabled = setup, enabled
        self._lock = threading.Lock()
        self._results: dict = {}  # stage -> (key, data, seconds)
        self._keys: dict = {}
        self._proc = None
        self._todo: list = []
        self._timer = None
        self._closed = False
        self._paused = False
        self._moves = 0  # redraws so far (a start that raced with one leaves its process paused)
        self._values: dict = {}

    def pause(self) -> None:
        """A redraw starts: pause the background at once (the page's redraw gets the cores)."""
        with self._lock:
            self._moves += 1
            if self._timer is not None:
                self._timer.cancel()
            if self.enabled and not self._closed:
                self._signal_locked(signal.SIGSTOP)

    def submit(self, values: dict) -> None:
        """The controls moved: compute what their keys lack, once they stay still."""
        with self._lock:
            self._moves += 1
            self._keys = stage_keys(values)
            self._values = dict(values)
            if self._timer is not None:
                self._timer.cancel()
            if not self.enabled or self._closed:
                return
            self._signal_locked(signal.SIGSTOP)  # the page's redraws first: paused, not lost
            self._timer = threading.Timer(QUIET_S, self._start)
            self._timer.daemon = True
            self._timer.start()

    def _start(self) -> None:
        """The controls have been still: resume, or end the old process and start a new one.

        Ending and spawning happen outside the lock: a redraw meanwhile (``pause``,
        ``submit``) never waits for a process to end or start.
        """
        with self._lock:
            if self._closed:
                return
            todo = [(s, k) for s, k in self._keys.items()
                    if self._results.get(s, (None,))[0] != k]
            running = self._proc is not None and self._proc.is_alive()
            if running and all(item in self._todo for item in todo):
                self._signal_locked(signal.SIGCONT)
                return  # the running process already computes these keys
            old, paused = self._proc, self._paused
            self._proc, self._todo, self._paused = None, [], False
            values, moves = self._values, self._moves
        _end(old, paused)
        if not todo:
            return
        ctx = multiprocessing.get_context("spawn")
        parent, child = ctx.Pipe(duplex=False)
        proc = ctx.Process(target=_work, args=(dumps(self.setup), values, todo, child),
                           daemon=True, name="fl-design-ui-background")
        proc.start()
        child.close()
        with self._lock:
            lost = self._closed or self._proc is not None  # closed, or another start won
            if not lost:
                self._proc, self._todo = proc, todo
                if self._moves != moves:  # the controls moved while it started: paused too
                    self._signal_locked(signal.SIGSTOP)
        if lost:
            _end(proc, False)
            parent.close()
            return
        threading.Thread(target=self._read, args=(proc, parent), daemon=True).start()

    def _read(self, proc, conn) -> None:
        while True:
            try:
                if not conn.poll(1.0):
                    if not proc.is_alive() and not conn.poll(0):
                        break
                    continue
                stage, key, data, seconds = conn.recv()
            except (EOFError, OSError):
                break
            with self._lock:
                self._results[stage] = (key, data, seconds)
        conn.close()

    def _signal_locked(self, sig) -> None:
        """Send ``sig`` to the background process's group (SIGSTOP pauses, SIGCONT resumes)."""
        proc = self._proc
        if proc is None or not proc.is_alive() or self._paused == (sig == signal.SIGSTOP):
            return
        try:
            os.killpg(proc.pid, sig)
        except (ProcessLookupError, PermissionError):  # before its setsid: the process alone
            try:
                os.kill(proc.pid, sig)
            except ProcessLookupError:
                return
        self._paused = sig == signal.SIGSTOP

    def snapshot(self) -> dict:
        """Each stage's state (ready, computing, waiting, stale) and its data when ready.

        Returns
        -------
        dict
            Stage -> ``{"state", "data", "seconds"}``; ``stale``: a result for earlier controls
            (shown greyed while the new one is computed).
        """
        with self._lock:
            running = {s for s, _ in self._todo} if self._proc is not None \
                and self._proc.is_alive() else set()
            out = {}
            for s in STAGES:
                key, data, sec = self._results.get(s, (None, None, None))
                fresh = key is not None and key == self._keys.get(s)
                busy = "paused while the controls move" if self._paused else "computing"
                state = "ready" if fresh else (busy if s in running else
                                               ("stale" if key is not None else "waiting"))
                out[s] = {"state": state, "data": data, "seconds": sec}
            return out

    def close(self) -> None:
        """End the background process (its whole group) and the pending timer."""
        with self._lock:
            self._closed = True
            if self._timer is not None:
                self._timer.cancel()
            old, paused = self._proc, self._paused
            self._proc, self._todo, self._paused = None, [], False
        _end(old, paused)


__all__ = ["BENCH_STEPS", "MAP_POINTS", "QUIET_S", "STAGES", "Background", "class_words",
           "stage_keys"]
