"""The compiled step's inputs against ``Design.step``'s: the recorded run both are fed, the errors.

The software-in-the-loop (:mod:`fl_design.codegen._sil`), processor-in-the-loop
(:mod:`fl_design.codegen._pil`) and float-prediction (:mod:`fl_design.codegen._float_check`)
checks all compare the inputs ``u`` a compiled (or emulated) step computes from measurements
``ym`` with those of ``Design.step`` fed the same measurements from the same firmware start
(the observer at rest at ``ym[0]``, ``u`` at the scenario's ``u0``). :class:`InputComparison`
holds both and their errors; :func:`recorded_run` is the measurement record of
:func:`fl_design.simulate` and :func:`reference_inputs` the reference.

Examples
--------
>>> import numpy as np
>>> from fl_design.codegen._compare import InputComparison
>>> c = InputComparison("float", np.zeros(3), np.array([1.0, 2.0, 2.0]), np.full(3, 2.0), 1e-4)
>>> c.max_abs_error, c.max_rel_error, c.matches
(1.0, 0.5, False)
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

#: relative bound of the double build (fraction of max |u|)
DOUBLE_BOUND = 1e-12
#: relative bound of the single-precision build (fraction of max |u|)
FLOAT_BOUND = 1e-4

def bound_for(precision: str) -> float:
    """The documented relative bound of :func:`software_in_the_loop` for ``precision``.

    Parameters
    ----------
    precision : str
        ``"double"`` or ``"float"``.

    Returns
    -------
    float

    Examples
    --------
    >>> from fl_design.codegen._compare import bound_for
    >>> bound_for("float") > bound_for("double")
    True
    """
    return FLOAT_BOUND if precision == "float" else DOUBLE_BOUND




@dataclass(frozen=True)
class InputComparison:
    """Inputs of a compiled step and of ``Design.step`` fed the same measurements.

    Parameters
    ----------
    precision : str
        Of the package.
    ym : numpy.ndarray
        ``(N,)`` measurements the step received.
    u_c : numpy.ndarray
        ``(N,)`` inputs of the compiled step.
    u_ref : numpy.ndarray
        ``(N,)`` inputs of ``Design.step`` fed ``ym`` from the same start.
    bound : float
        Relative bound (fraction of ``max |u_ref|``).

    Attributes
    ----------
    max_abs_error, max_rel_error, tail_rel_error : float
        ``max |u_c - u_ref|``, divided by ``max |u_ref|``, and the latter over the last tenth
        (over the samples before the first non-finite one, if any).
    matches : bool
        Both relative errors within ``bound``.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.codegen._compare import InputComparison
    >>> c = InputComparison("double", np.zeros(2), np.ones(2), np.ones(2), 1e-12)
    >>> c.matches, c.errors()["max_rel_error"]
    (True, 0.0)
    """

    precision: str
    ym: np.ndarray
    u_c: np.ndarray
    u_ref: np.ndarray
    bound: float

    @property
    def _finite(self) -> slice:
        ok = np.isfinite(self.u_c) & np.isfinite(self.u_ref)
        n = int(np.argmin(ok)) if not ok.all() else ok.size
        return slice(0, max(n, 1))

    @property
    def max_abs_error(self) -> float:
        """``max |u_c - u_ref|`` (before any non-finite sample)."""
        k = self._finite
        return float(np.max(np.abs(self.u_c[k] - self.u_ref[k])))

    @property
    def _scale(self) -> float:
        return max(float(np.max(np.abs(self.u_ref[self._finite]))), np.finfo(float).tiny)

    @property
    def max_rel_error(self) -> float:
        """``max |u_c - u_ref| / max |u_ref|``."""
        return self.max_abs_error / self._scale

    @property
    def tail_rel_error(self) -> float:
        """The relative error over the last tenth of the (finite part of the) run."""
        u_c, u_ref = self.u_c[self._finite], self.u_ref[self._finite]
        k = max(1, u_c.size // 10)
        return float(np.max(np.abs(u_c[-k:] - u_ref[-k:]))) / self._scale

    @property
    def matches(self) -> bool:
        """The step equals ``Design.step`` within the bound, over the run and its last tenth."""
        return bool(self.max_rel_error <= self.bound and self.tail_rel_error <= self.bound)

    def errors(self) -> dict:
        """Strict-JSON summary of the comparison (no sample arrays).

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.codegen._compare import InputComparison
        >>> sorted(InputComparison("float", np.zeros(1), np.ones(1), np.ones(1), 1e-4).errors())
        ['bound', 'matches', 'max_abs_error', 'max_rel_error', 'n_samples', 'precision', 'tail_rel_error']
        """
        return {"precision": self.precision, "n_samples": int(self.u_c.size),
                "max_abs_error": self.max_abs_error, "max_rel_error": self.max_rel_error,
                "tail_rel_error": self.tail_rel_error, "bound": float(self.bound),
                "matches": self.matches}


def recorded_run(plant, design, scenario, *, max_samples: int | None = None):
    """``(ym, r, u0)``: the measurements and references of :func:`fl_design.simulate`'s run.

    Cut at ``max_samples`` and before the first non-finite measurement (a diverged run);
    ``u0`` is the input the run starts from (the firmware's ``start(ym[0], u0)``).

    Parameters
    ----------
    plant : Plant
        The plant.
    design : Design
        The user's design.
    scenario : Scenario
        Reference, duration, noise.
    max_samples : int, optional
        At most this many samples (default: all).

    Returns
    -------
    tuple of (numpy.ndarray, numpy.ndarray, float)

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design import presets
    >>> from fl_design.codegen._compare import recorded_run
    >>> ym, r, u0 = recorded_run(fl.plants.trms_yaw(), presets.paper_design(),
    ...                          fl.Scenario(0.3, 0.1), max_samples=50)
    >>> ym.shape, float(r[0]), u0
    ((50,), 0.3, 0.0)
    """
    from ..sim import simulate
    from ..sim._run import prepare_run

    run = prepare_run(plant, design, scenario)
    ym = simulate(plant, design, run.scenario).ym
    finite = np.isfinite(ym)
    n = ym.size if finite.all() else int(np.argmin(finite))
    n = max(1, n if max_samples is None else min(max_samples, n))
    return ym[:n], run.r[:n], float(run.u0)


def reference_inputs(design, ym, r, u0: float) -> np.ndarray:
    """The inputs of ``Design.step`` fed ``ym, r`` from the firmware start ``(ym[0], u0)``.

    Parameters
    ----------
    design : Design
        The design the step was generated from (``CPackage.step_design``).
    ym, r : numpy.ndarray
        ``(N,)`` measurements and references.
    u0 : float
        The start's input.

    Returns
    -------
    numpy.ndarray
        ``(N,)``.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design import presets
    >>> from fl_design.codegen._compare import reference_inputs
    >>> reference_inputs(presets.paper_design(), np.zeros(3), np.zeros(3), 0.5).tolist()
    [0.5, 0.5, 0.5]
    """
    state0 = design.initial_state(y0=float(ym[0]), u0=u0)
    return reference_run(design, ym, r, state0=state0)[0]


def reference_run(design, ym, r, *, state0=None, chunk: int = 20_000):
    """``Design.step`` (CasADi's interpreter) fed ``ym, r``: inputs, estimates, states.

    The step is accumulated over chunks of samples (``mapaccum``), the state carried from
    chunk to chunk: linear in the number of samples (about 4 us per sample).

    Parameters
    ----------
    design : Design
        The design.
    ym, r : numpy.ndarray
        ``(N,)`` measurements and references.
    state0 : array_like, optional
        Start state (default :meth:`Design.initial_state`).
    chunk : int, optional
        Samples per ``mapaccum``.

    Returns
    -------
    u : numpy.ndarray
        ``(N,)``.
    xhat : numpy.ndarray
        ``(N, rho + 1)`` clamped estimates.
    states : numpy.ndarray
        ``(N, state_size)`` states after each sample.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design import presets
    >>> from fl_design.codegen._compare import reference_run
    >>> d = presets.paper_design()
    >>> y, r = np.linspace(0, 0.1, 7), np.full(7, 0.3)
    >>> u, xhat, states = reference_run(d, y, r, chunk=3)
    >>> np.allclose(u, d.run(y, r).u, rtol=0, atol=1e-15), xhat.shape
    (True, (7, 3))
    """
    p0 = ca.DM(design.parameter_vector())
    s, y_, r_ = ca.SX.sym("s", design.state_size), ca.SX.sym("y"), ca.SX.sym("r")
    s_next, u, xhat = design.parametric_step(s, y_, r_, p0)
    f = ca.Function("fl_sil_ref", [s, y_, r_], [s_next, u, xhat])
    state = design.initial_state() if state0 is None else np.asarray(state0, dtype=float)
    us, xs, ss, maps = [], [], [], {}
    for start in range(0, len(ym), chunk):
        y_c, r_c = ym[start:start + chunk], r[start:start + chunk]
        if y_c.size not in maps:  # building a mapaccum costs more than running it: reuse
            maps[y_c.size] = f.mapaccum("fl_ref", y_c.size)
        states, u_c, x_c = maps[y_c.size](state, y_c[None, :], r_c[None, :])
        states = np.asarray(states, dtype=float)
        state = states[:, -1]
        ss.append(states.T)
        us.append(np.asarray(u_c, dtype=float).ravel())
        xs.append(np.asarray(x_c, dtype=float).T)
    return np.concatenate(us), np.concatenate(xs), np.concatenate(ss)


__all__ = ["DOUBLE_BOUND", "FLOAT_BOUND", "InputComparison", "bound_for", "recorded_run",
           "reference_inputs", "reference_run"]
