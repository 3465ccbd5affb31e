"""The largest region of a plant where the nonlinear (LDI) certificate holds, and what it covers.

:func:`nonlinear_region` scales the plant's region box and input range about the equilibrium
by a factor ``s`` in ``(0, 1]`` (every state that ``sigma`` depends on: ``x_eq + s (box -
x_eq)``, the others keep their range; the input ``u_eq + s (range - u_eq)``), encloses ``b`` and ``d sigma/d xi`` there by interval arithmetic
(:func:`._plant_bounds.plant_bounds`) and asks :func:`fl_design.certify_eps` for the nonlinear
certificate at the design's own ``eps`` (:func:`._ldi.ldi_point`). It tries ``s = 1``, then
bisects ``log s`` between the smallest scale ``s_min`` and the largest failing one (``steps``
times), then the input range's scale alone between ``s`` and 1 (``steps`` times, the states
kept at ``s``: the input range sets the ``b`` interval and the saturation room), and again
with the states at ``s/10`` and ``s/100`` (at most 6 steps each: a smaller state box admits a
wider input range). Of the widest input range certified at each state scale, the region
reported is the one whose covered starts are widest (relative to the plant's region). The boxes are nested, so a certificate at ``s`` covers the plant in that box; the
bisection need not find the largest such ``s`` when the solver's success is not monotone.

The covered initial states are the certificate's :class:`._ldi.CoveredSet` (the largest
sublevel set ``V(X) <= c`` of the loop state ``X = (x - x_eq, observer, u, z)`` inside the
region and the input range, which includes the saturation-inactive set): every trajectory
starting in it stays in it (observer peaking included: ``V`` bounds the whole loop state)
and converges. With the observer started as usual (at rest at the first measurement,
``xhat = (y0, 0, ..., 0)``, ``u0 = u_eq``) the loop state is ``X0 = G (x0 - x_eq)``; the plant
starts covered are the ellipsoid ``(x0 - x_eq)^T G^T P G (x0 - x_eq) <= c``, reported as its
extent along each state alone and a box of starts that is covered as a whole (half-widths
``t e_i`` with ``t^2 e^T |G^T P G| e <= c``).

Plants with internal dynamics (``rho < n``) are refused with what would be needed, and so are
plants whose normal-form coordinates are not their states (the TRMS with motor lag: ``xi =
(phi, phi', phi'')``): the region is a box in ``x``, ``V`` and the covered set live in ``xi``,
and each enclosure goes through ``(d xi/d x)^-1`` (a single one took minutes).

Examples
--------
>>> import fl_design as fl
>>> r = nonlinear_region(fl.presets.pendulum_design(), fl.plants.pendulum(), steps=2)
>>> r.certified, r.scale, r.covered.binding   # the whole region: |theta| <= pi, |u| <= 20
(True, 1.0, 'u')
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .. import _validate as V
from ..errors import ParameterError
from ._cert_results import _Result
from ._plant_bounds import plant_bounds

#: State scales ``s, s/10, ...`` at which the input range is searched (widest starts kept).
STATE_TRIES = 3


@dataclass(frozen=True, repr=False)
class NonlinearRegion(_Result):
    """The region search of :func:`nonlinear_region` and the initial states it covers.

    Parameters
    ----------
    certified : bool
        A nonlinear certificate was found at some scale.
    scale : float
        The largest certified scale found (0 when none).
    region : tuple of (str, float, float)
        The certified state box (empty when none).
    input_range : (float, float) or None
        The certified input range.
    eps, gamma : float
        The design's observer time constant and gain.
    covered : CoveredSet or None
        The covered loop states ``V(X) <= c``.
    q : float
        Contraction of ``V``'s ``P`` over every sample map (``V(X+) <= q^2 V(X)``; NaN: none).
    lyapunov_source : str
        Which ``P`` the covered set uses: the certificate's, or one chosen for the widest
        covered starts (:mod:`._covered_lmi`), re-checked.
    start_extents : tuple of (str, float)
        Largest ``|x_i - x_eq,i|`` of a covered plant start, the other states at equilibrium
        and the observer at rest at the first measurement.
    start_box : tuple of (str, float)
        Half-widths of a box of plant starts covered as a whole (same observer start).
    reason : str
        The certificate's reason at ``scale``, or why nothing was certified.
    whole_reason : str
        Why the plant's whole region (scale 1) is not certified ("" when it is).
    tried : tuple of (float, bool)
        Every scale tried and whether it certified.
    input_scale : float
        The input range's scale (>= ``scale``: searched second, the states at ``scale``).
    tried_input : tuple of (float, float, bool)
        Every ``(scale, input_scale)`` tried and whether it certified.
    largest : (float, float)
        The largest certified state scale found, and the widest input scale with it; the
        region reported is the one (the widest input range certified at each state scale
        tried) whose covered starts are widest.
    seconds : float
        Wall time of the search.

    Examples
    --------
    >>> import fl_design as fl
    >>> r = nonlinear_region(fl.presets.pendulum_design(), fl.plants.pendulum(), steps=0)
    >>> r.tried
    ((1.0, True),)
    """

    certified: bool
    scale: float
    region: tuple
    input_range: tuple | None
    eps: float
    gamma: float
    covered: object
    q: float
    lyapunov_source: str
    start_extents: tuple
    start_box: tuple
    reason: str
    whole_reason: str
    tried: tuple
    seconds: float
    input_scale: float = 0.0
    tried_input: tuple = ()
    largest: tuple = ()

    def words(self) -> str:
        """One line: ``nonlinear: certified in region ... (covered initial states ...)``.

        Examples
        --------
        >>> import fl_design as fl
        >>> r = nonlinear_region(fl.presets.pendulum_design(), fl.plants.pendulum(), steps=0)
        >>> r.words().startswith("nonlinear: certified in region theta in [")
        True
        """
        if not self.certified:
            return f"nonlinear: not certified in any region tried: {self.reason}"
        reg = ", ".join(f"{n} in [{lo:.4g}, {hi:.4g}]" for n, lo, hi in self.region)
        if self.input_range is not None:
            reg += f", u in [{self.input_range[0]:.4g}, {self.input_range[1]:.4g}]"
        if self.covered is None:
            return f"nonlinear: certified in region {reg} (scale {self.scale:.3g}); {self.reason}"
        starts = ", ".join(f"|{n} - {n}_eq| <= {w:.3g}" for n, w in self.start_extents)
        box = ", ".join(f"|{n} - {n}_eq| <= {w:.3g}" for n, w in self.start_box)
        whole = f"; not in the whole region: {self.whole_reason}" if self.whole_reason else ""
        big = ("" if tuple(self.largest) == (self.scale, self.input_scale) else
               f"; the largest certified: scale {self.largest[0]:.3g}, input "
               f"{self.largest[1]:.3g}")
        return (f"nonlinear: certified in region {reg} (scale {self.scale:.3g} of the plant's, "
                f"input {self.input_scale:.3g}{big}) "
                f"(covered initial states: V <= {self.covered.level:.4g}, e.g. {starts} alone, "
                f"or the box {box}; observer at rest at the first measurement; V: "
                f"{self.lyapunov_source}){whole}")

    def summary(self) -> str:
        """A few words for a report's summary: where it holds and which plant starts it covers.

        Examples
        --------
        >>> import fl_design as fl
        >>> nonlinear_region(fl.presets.pendulum_design(), fl.plants.pendulum(),
        ...                  steps=0).summary()  # doctest: +ELLIPSIS
        "certified in the plant's whole region; covered starts ..."
        """
        if not self.certified:
            return "not certified in any region tried"
        whole = self.scale >= 1.0 and (self.input_range is None or self.input_scale >= 1.0)
        if whole:
            where = "in the plant's whole region"
        else:
            parts = [f"{n} in [{lo:.3g}, {hi:.3g}]" for n, lo, hi in self.region]
            if self.input_range is not None:
                parts.append(f"u in [{self.input_range[0]:.3g}, {self.input_range[1]:.3g}]")
            where = f"only in the region {', '.join(parts)}"
        if not self.start_extents:
            return f"certified {where}"
        starts = ", ".join(f"|{n} - {n}_eq| <= {w:.2g}" for n, w in self.start_extents)
        return f"certified {where}; covered starts {starts} (each alone, observer at rest)"

    def _repr_lines(self):
        return [self.words(), "tried scales: " + ", ".join(
            f"{s:.3g} {'ok' if ok else 'no'}" for s, ok in self.tried)
            + "; (scale, input scale): " + (", ".join(
                f"({s:.3g}, {u:.3g}) {'ok' if ok else 'no'}" for s, u, ok in self.tried_input)
                or "none")
            + f" ({self.seconds:.1f} s)"]


def _scaled(plant, s: float, s_u: float):
    """The state box and input range scaled by ``s`` about the equilibrium.

    States on which ``sigma = y^(rho)`` does not depend keep their whole range (they change
    no enclosure).
    """
    x_eq = [float(v) for v in plant.x_op]
    chain = plant._lie_chain()
    used = chain.derivatives[chain.rho].free_symbols
    region = {}
    for st, xe in zip(plant.states, x_eq):
        lo, hi = plant.region[st]
        k = s if st in used else 1.0
        region[str(st)] = (xe - k * (xe - lo), xe + k * (hi - xe))
    ur = None
    if plant.input_range is not None:
        lo, hi = plant.input_range
        ue = float(plant.u_eq)
        ur = (ue - s_u * (ue - lo), ue + s_u * (hi - ue))
    return region, ur


def _check_chain(plant) -> None:
    """Refuse, saying why, a plant whose normal-form coordinates are not its states."""
    chain = plant._lie_chain()
    if chain.rho != plant.n:
        raise ParameterError(
            f"no nonlinear certificate for {plant.name!r}: it has internal dynamics (rho = "
            f"{chain.rho} < n = {plant.n}); the LDI certificate covers rho = n only. Needed: "
            f"the normal form (xi, eta) with the {plant.n - chain.rho} internal states eta' = "
            "q(xi, eta) and interval bounds on the Jacobian of q, added to the loop (the "
            "surrogate models only the chain of rho integrators), and a region in those "
            "coordinates")
    if any(d != x for d, x in zip(chain.derivatives[: chain.rho], plant.states)):
        raise ParameterError(
            f"no nonlinear region search for {plant.name!r}: its normal-form coordinates xi = "
            f"({', '.join(str(d) for d in chain.derivatives[: chain.rho])}) are not its "
            "states, so a box of states is not a box of xi (where V and the covered set live) "
            "and the enclosures of d sigma/d xi go through (d xi/d x)^-1 (slow). Needed: a "
            "region given in xi (or an inner xi-box of the state box); certify_eps with "
            "plant_bounds(..., region=...) and a_jacobian_bounds='plant' still certifies one "
            "region")


def _try(design, plant, s, params, splits, s_u=None):
    from ._certify import certify_eps

    region, ur = _scaled(plant, s, s if s_u is None else s_u)
    pb = plant_bounds(plant, params=params, region=region, T=design.T, input_range=ur,
                      splits=splits)
    if pb.a_jacobian_bounds is None:
        raise ParameterError(f"no nonlinear certificate for {plant.name!r}: "
                             f"{pb.jacobian_note}")
    cert = certify_eps(design, pb, a_jacobian_bounds="plant", search=False)
    return cert, pb


def _start_map(design, plant):
    """``G``: the kept loop state of a plant start ``x0 - x_eq``, the observer at rest."""
    from ._surrogate import SurrogateLoop

    rho, keep = design.rho, SurrogateLoop(design).keep
    u_eq, y_eq = float(plant.u_eq), float(plant.x_op[0])
    s0 = design.initial_state(y0=y_eq, u0=u_eq)
    ds = design.initial_state(y0=y_eq + 1.0, u0=u_eq) - s0  # linear in y0
    G = np.zeros((rho + s0.size, rho))
    G[:rho, :rho] = np.eye(rho)
    G[rho:, 0] = ds
    return G[keep]


def _starts(plant, cs, G):
    """``(extents, box)`` of the plant starts covered by ``cs`` with the observer at rest."""
    Q = G.T @ cs.P @ G
    Q = (Q + Q.T) / 2
    names = [str(v) for v in plant.states]
    ext = [math.sqrt(cs.level / Q[i, i]) for i in range(Q.shape[0])]
    e = np.array(ext)
    t = math.sqrt(cs.level / float(e @ np.abs(Q) @ e))
    return tuple(zip(names, ext)), tuple(zip(names, (t * w for w in ext)))


def _widest(design, plant, pb, G, cs):
    """A covered set from a P chosen for the widest starts, when wider than ``cs``'s."""
    from ._certify import _Loop
    from ._ldi import widest_covered_set

    L = _Loop(design, pb.b_bounds, pb.a_jacobian_bounds, 41, 8)
    w = np.array([min(xe - lo, hi - xe) for xe, (lo, hi) in zip(pb.xi_op, pb.xi_region)])
    out = widest_covered_set(L, float(design.estimator.eps), float(design.controller.gamma),
                             pb, G, w)
    if out is None:
        return None
    new, q = out
    if new.level <= 0:
        return None

    def size(c):
        return min(b / wi for (_, b), wi in zip(_starts(plant, c, G)[1], w))
    return (new, q) if size(new) > size(cs) else None


def nonlinear_region(design, plant, *, params=None, s_min: float = 1e-6, steps: int = 12,
                     splits: int = 8) -> NonlinearRegion:
    """Search the largest scaled region where the nonlinear certificate holds (module docstring).

    Parameters
    ----------
    design : Design
        An EHGO design (certified at its own eps and gamma).
    plant : Plant
        The plant (``rho = n``; its region gives every state a range).
    params : dict, optional
        Parameter box ``{name: (lo, hi)}`` covered as well.
    s_min : float, optional
        Smallest scale tried (default 1e-6).
    steps : int, optional
        Bisection steps of ``log s`` (default 12).
    splits : int, optional
        Sub-intervals per variable of the interval enclosures.

    Returns
    -------
    NonlinearRegion

    Raises
    ------
    ParameterError
        A plant with internal dynamics or whose normal-form coordinates are not its states
        (the reason says what would be needed), a bad scale.

    Examples
    --------
    >>> import fl_design as fl
    >>> r = nonlinear_region(fl.presets.pendulum_design(), fl.plants.pendulum(), steps=3)
    >>> r.covered.binding in r.covered.names
    True
    """
    s_min = V.positive("s_min", s_min)
    if not s_min < 1.0:
        raise ParameterError(f"s_min must be in (0, 1), got {s_min!r}")
    steps = V.integer("steps", steps, minimum=0)
    _check_chain(plant)
    t0 = time.perf_counter()
    tried, tried_u, best, fail_reason, whole, ok = [], [], None, "", "", []
    lo, hi = None, None
    for s in (1.0, s_min):
        cert, pb = _try(design, plant, s, params, splits)
        tried.append((s, bool(cert.certified)))
        if cert.certified:
            best, lo = (s, cert, pb), s
            ok.append((s, s, cert, pb))
            break
        hi, fail_reason = s, cert.point.reason
        whole = whole or fail_reason
    if best is not None and lo < 1.0:
        for _ in range(steps):
            mid = math.sqrt(lo * hi)
            cert, pb = _try(design, plant, mid, params, splits)
            tried.append((mid, bool(cert.certified)))
            if cert.certified:
                best, lo = (mid, cert, pb), mid
                ok.append((mid, mid, cert, pb))
            else:
                hi = mid
        # then the input range alone, the states kept at the scale found, and at smaller
        # state scales (a smaller state box admits a wider input range)
        largest_x, s_u0 = lo, lo
        for k, s_x in enumerate(largest_x / 10.0 ** i for i in range(STATE_TRIES)):
            if s_x < s_min or plant.input_range is None:
                break
            lo_u, hi_u = s_u0, 1.0
            for _ in range(steps if k == 0 else min(steps, 6)):
                mid = math.sqrt(lo_u * hi_u)
                cert, pb = _try(design, plant, s_x, params, splits, mid)
                tried_u.append((s_x, mid, bool(cert.certified)))
                if cert.certified:
                    lo_u = mid
                    ok.append((s_x, mid, cert, pb))
                else:
                    hi_u = mid
            s_u0 = lo_u
    eps, gamma = float(design.estimator.eps), float(design.controller.gamma)
    if best is None:
        return NonlinearRegion(False, 0.0, (), None, eps, gamma, None, math.nan, "", (), (),
                               f"at scale {s_min:g} of the plant's region: {fail_reason}",
                               whole,
                               tuple(tried), time.perf_counter() - t0, 0.0, ())
    G = _start_map(design, plant)
    full = [min(xe - lo_, hi_ - xe) for xe, (lo_, hi_) in
            zip((float(v) for v in plant.x_op), (plant.region[v] for v in plant.states))]
    last = {}  # the widest input range certified at each state scale, and the largest region
    for sx, su, c, p in ok:
        last[sx] = (sx, su, c, p)
    picks = [_covered(design, plant, c, p, G, full) + (sx, su, p)
             for sx, su, c, p in {id(v): v for v in [*last.values(), ok[-1]]}.values()]
    _, cs, q, source, ext, box, reason, s, s_u, pb = max(picks, key=lambda r: r[0])
    return NonlinearRegion(True, float(s), pb.region, pb.input_range, eps, gamma, cs, q,
                           source, ext, box, reason, whole, tuple(tried),
                           time.perf_counter() - t0, float(s_u), tuple(tried_u),
                           max((float(a), float(b)) for a, b, _, _ in ok))


def _covered(design, plant, cert, pb, G, full):
    """``(size, cs, q, source, extents, box, reason)`` of one certified region."""
    cs, reason = cert.covered_set, cert.point.reason
    q = float(reason.split(" = ")[-1].split(" ")[0])  # the certificate's contraction
    source = "the certificate's P"
    if cs is None or pb.xi_region is None:
        return (-1.0, None, q, source, (), (), (
            "no covered set: the normal-form coordinates are not the plant's states (the "
            "region is a box in x, V lives in xi = (y, ..., y^(rho-1)))"))
    if cs.level <= 0:
        return 0.0, cs, q, source, (), (), reason
    wide = _widest(design, plant, pb, G, cs)
    if wide is not None:
        cs, q = wide
        source = (f"P chosen for the widest covered starts (LMI), re-checked: every sample "
                  f"map contracts V by {q:.12f} < 1 (NumPy)")
    ext, box = _starts(plant, cs, G)
    return min(b / w for (_, b), w in zip(box, full)), cs, q, source, ext, box, reason


__all__ = ["NonlinearRegion", "nonlinear_region"]
