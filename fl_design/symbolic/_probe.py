"""Deterministic probe points of a plant and the exact "is it identically zero?" test.

The relative degree is decided by whether ``d y^(i)/du`` is identically zero: exactly, never by
comparing numbers with the plant's magnitudes (``x2' = -1e10*x1 + u``, ``-x1 + 1e-12*u`` and
``x1**30 + u`` are actuated). Numbers at probe points only prove an expression nonzero (its
value far above the round-off of its own terms) or trigger a
:class:`~fl_design.errors.PoorlyScaledWarning`.

Examples
--------
>>> import sympy as sp
>>> import fl_design as fl
>>> from fl_design.symbolic._probe import _Probe, _identically_zero
>>> x1, x2, u = sp.symbols("x1 x2 u", real=True)
>>> plant = fl.Plant.from_ode([x1, x2], u, [x2, -x1 + 1e-12*u], x1)
>>> probe = _Probe(plant)
>>> _identically_zero(sp.Float(1e-12), probe), _identically_zero(sp.sin(x1)**2 + sp.cos(x1)**2 - 1, probe)
(False, True)
"""

from __future__ import annotations

import warnings

import numpy as np
import sympy as sp

from ..errors import PoorlyScaledWarning

_N_PROBE = 16  # random points for the numeric tests
_ZERO_TOL = 1e-10  # |expr| above this share of the sum of its terms' magnitudes: surely nonzero
_NEGLIGIBLE = 1e-14  # a nonzero input coefficient below this share of |y^(i)| gets a warning


class _Probe:
    """Deterministic random evaluation points in the plant's region (or around its operating point)."""

    def __init__(self, plant):
        rng = np.random.default_rng(0)
        cols = []
        for i, s in enumerate(plant.states):
            lo_hi = (plant.region or {}).get(s)
            cols.append(rng.uniform(*lo_hi, _N_PROBE) if lo_hi else plant.x_op[i] + rng.normal(0, 1, _N_PROBE))
        rng_u = plant.input_range
        cols.append(rng.uniform(*rng_u, _N_PROBE) if rng_u else plant.u_eq + rng.normal(0, 1, _N_PROBE))
        self.points = np.array(cols)
        self.symbols = [*plant.states, plant.input]
        self.params = plant.params

    def values(self, expr: sp.Expr) -> np.ndarray:
        fn = sp.lambdify(self.symbols, expr.subs(self.params), modules="numpy")
        with np.errstate(all="ignore"):
            out = np.asarray(fn(*self.points), dtype=float)
        return np.broadcast_to(out, (_N_PROBE,))


def _identically_zero(expr: sp.Expr, probe: _Probe, numbers: dict | None = None) -> bool:
    """Is ``expr`` identically zero? Decided against its own terms, not the plant's scale.

    ``expr`` may hold the plant's floating-point numbers as symbols (``numbers`` maps them back),
    so that a coefficient formed by a cancellation keeps its terms: ``C B = 0.3*0.2 - 0.06``
    stays three terms instead of folding into ``1e-17``. Exact when SymPy knows (``0``; a
    single nonzero number such as ``1e-12``). Else a probe point where ``|expr|`` exceeds
    ``1e-10`` of the sum of its terms' magnitudes proves it nonzero; a value at the round-off of
    its own terms everywhere is a cancellation (zero) when it involves the plant's numbers, and
    is decided by ``simplify`` otherwise.
    """
    numbers = numbers or {}
    value = expr.xreplace(numbers)
    if value == 0:
        return True
    if value.is_number and value.is_zero is not None and len(sp.Add.make_args(expr)) == 1:
        return bool(value.is_zero)
    terms = sp.Add.make_args(sp.expand_mul(expr) if sp.count_ops(expr) < 2000 else expr)
    vals = probe.values(value)
    mags = sum(np.abs(probe.values(sp.sympify(t).xreplace(numbers))) for t in terms)
    ok = np.isfinite(vals) & np.isfinite(mags)
    if np.any(np.abs(vals[ok]) > _ZERO_TOL * mags[ok]):
        return False
    if ok.any() and numbers and expr.free_symbols & set(numbers):
        return True  # a cancellation of the plant's own numbers, to their round-off
    return sp.simplify(value) == 0


def _negligible_note(plant, i: int, b: sp.Expr, y: sp.Expr, probe: _Probe) -> str | None:
    """A warning text when the (nonzero) input coefficient is at round-off against y^(i)."""
    vb, vy = np.abs(probe.values(b)), np.abs(probe.values(y))
    ok = np.isfinite(vb) & np.isfinite(vy)
    if ok.any() and np.all(vb[ok] <= _NEGLIGIBLE * vy[ok]):
        return (f"the input {plant.input} enters y^({i}) of plant {plant.name!r} with the "
                f"coefficient {_short(b)}, which is nonzero (relative degree {i}) but below "
                f"{_NEGLIGIBLE:g} of |y^({i})| at every probe point: the plant is at the limit "
                "of double precision there; rescale its states or units")
    return None


def warn_notes(notes) -> None:
    """Emit a derivation's notes as :class:`~fl_design.errors.PoorlyScaledWarning` (also when
    the derivation was read from the cache)."""
    for note in notes:
        warnings.warn(note, PoorlyScaledWarning, stacklevel=4)


def _short(expr, limit: int = 60) -> str:
    text = str(expr)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _check_b_scale(value: complex, b: sp.Expr, probe: _Probe) -> bool:
    """True when ``b`` vanishes at a point: its value there is 0, not finite, or below 1e-12
    of b's own magnitude over the probe points (not of the plant's other terms)."""
    scale = float(np.nanmax(np.abs(probe.values(b)), initial=0.0))
    return not np.isfinite(value) or value == 0 or abs(value) <= 1e-12 * scale
