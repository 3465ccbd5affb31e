"""Attack the class certificates: can any member of a certified class grow at its certified eps*?

For each class of :data:`bench_certify.CURVE_CLASSES` (the issue-33 spread: rho 1 to 4; wide,
narrow and negative ``b``; a rate bound on ``b``; a slope box for ``a``; T = 1 ms and 0.1 ms)
and a few gains, the certified ``eps*`` of :func:`fl_design.eps_star_curve` (and, in full
mode, the headline ``eps*`` of :func:`fl_design.certify_eps`) is attacked at ``eps*`` and at
``0.98 eps*`` with the class's own members, the loop built apart from fl_design
(:mod:`_attack_loop`: exact ZOH chain, Tustin EHGO, the dynamic controller, in mpmath; its
agreement with the library's linearization ``SurrogateLoop`` is checked first, at a frozen
``b``, by the traces of the powers of the two loop matrices):

* frozen members: ``b`` on a dense grid (and every slope-box corner);
* the joint spectral radius lower bound ``max rho(product)^(1/k)`` over all products of the
  vertices (``b`` ends x slope corners) of length ``k <= 8`` (fewer when there are many
  vertices), and dwell-time periodic switching ``M_j^q M_i^p``: every ``p, q <= 128`` (32 with
  a slope box or in quick mode: resonant dwells such as 9:19 samples, which products of
  length 8 miss) and long dwells up to 4096 samples; every pattern of three pairs of runs
  (each run 1..7 samples, 1..5 in quick mode: mixed dwells such as 5:2, 5:2, 4:2 samples,
  the library's own refutation at one control point); a hill climb (single-sample changes)
  from the best period found;
* greedy worst-case switching (at each step the member maximizing the next state's norm,
  Euclidean and the middle loop's Lyapunov norm), its trajectory growth and the radius of the
  products over its last 8..512 steps; random dwell sequences;
* with a rate bound (``|b_(k+1) - b_k| <= b_rate`` per sample, :class:`fl_design.PlantClass`):
  only such sequences: ``b`` on a grid of step ``b_rate``, greedy and random walks of one step,
  triangle waves at the full rate over sub-ranges.

A control in full mode: the same attacks at the refuted end of certify_eps's bracket (where
the library found a counterexample) should find growth: it shows the attacks have teeth.

Members are counted twice: within the coverage the result states (``covers``: ``frozen`` =
constant ``b`` only) and within the class its one-line description names (e.g. "b in [1, 50]
varying arbitrarily"). An attack **beats** a certificate when it shows growth: a product
of members whose radius, per sample, exceeds 1 + 1e-9, confirmed in mpmath at 40 digits (the
double-precision eigenvalues of these near-unit-circle, ill-conditioned loops are off by up to
~1e-9). Trajectories growing more than 10x (``||X_N|| / max_(k <= N/2) ||X_k||``) are
reported too, but count only through the products of their own member sequences (windows of
the greedy sequence): at rho >= 3 a stable switched loop amplifies a state thousands of times
for a while (Lyapunov matrices of condition ~1e9), so a trajectory alone proves nothing. Prints per class the gains attacked, the
best growth and the margin ``1 - growth``; exits 1 when any attack beats a certificate (the
named class or the stated coverage).

    python verify/attack_certificates.py [--quick] [--seed N] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import ast
import sys
import time

import numpy as np
from _attack_loop import loop_matrix
from _attack_runs import CONFIRM, attack_target
from _shared import load_line
from bench_certify import CURVE_CLASSES

import fl_design as fl

#: The gains' indices (of the bench's 12 log-spaced gains) attacked: full and quick mode.
GAIN_INDEX = {"full": (2, 6, 10), "quick": (6,)}
#: Quick mode's gain where index 6 is not certified (the slope box's curve certifies its
#: lowest gains only; trying index 6 first costs seconds).
QUICK_INDEX = {"rho 2, T 1 ms, b in [1, 5], a-slope box": 0}
#: Certificate calls that raised (a failure of the run, not an attack's beat).
CRASHES: list = []
#: The fractions of the certified eps* attacked.
FRACTIONS = (1.0, 0.98)


def _keywords(kw: str) -> dict:
    """The PlantClass keywords of a CURVE_CLASSES entry, read as literals (never evaluated)."""
    call = ast.parse(f"f({kw})", mode="eval").body
    return {k.arg: ast.literal_eval(k.value) for k in call.keywords}


def class_and_design(rho, T, decay, kw):
    """The bench's class and design (as :data:`bench_certify.CURVE_CLASSES` builds them), its
    12 gains (magnitudes) and eps range."""
    cls = fl.PlantClass(rho=rho, T=T, **_keywords(kw))
    s = 1.0 if cls.b[0] > 0 else -1.0
    bm = max(abs(x) for x in cls.b)
    d = fl.Design(estimator=fl.EHGO(rho, 10 * T, T),
                  controller=fl.DynamicController(fl.synthesize_gains(rho, decay=decay).gains,
                                                  s * 0.5 / bm))
    return cls, d, np.geomspace(0.02 / bm, 1.0 / bm, 12), (
        (1e-3, 1.0) if T >= 1e-3 else (1e-4, 0.1))


def agreement(d, cls, eps, gamma) -> float:
    """Largest relative difference of ``trace(M^j)``, j = 1..n, between this loop and the
    library's ``SurrogateLoop`` at the middle ``b`` (and the box's first corner)."""
    from fl_design.analysis._surrogate import SurrogateLoop

    b = 0.5 * (cls.b[0] + cls.b[1])
    a_row = None if cls.a_slopes is None else [p[1] for p in cls.a_slopes]
    g = np.sign(b) * gamma
    mine = loop_matrix(rho=d.rho, T=d.T, eps=eps, alphas=d.estimator.alphas,
                       gains=d.controller.gains, gamma=g, b=b, ki=d.controller.ki, a_row=a_row)
    L = SurrogateLoop(d)
    M0, M1 = L.parts(eps, abs(g), a_row)  # the library's loop: |b| and |gamma|
    lib = (M0 + abs(b) * M1)[np.ix_(L.keep, L.keep)]
    worst = 0.0
    for j in range(1, mine.shape[0] + 1):
        t1 = np.trace(np.linalg.matrix_power(mine, j))
        t2 = np.trace(np.linalg.matrix_power(lib, j))
        worst = max(worst, abs(t1 - t2) / max(abs(t2), 1.0))
    return worst


def targets(d, cls, gamma, er, full: bool):
    """``[(source, covers, eps*, class description, refuted eps or None, class named)]``: the
    curve's certified eps* and, in full mode, the headline of certify_eps (with the refuted end
    of its bracket: the control), at ``gamma``."""
    out = []
    curve = fl.eps_star_curve(d, cls, [gamma], eps_range=er)
    if np.isfinite(curve.eps_star_certified[0]):
        out.append(("eps_star_curve", curve.covers, float(curve.eps_star_certified[0]),
                    curve.class_description, None, curve.plant_class))
    if full:
        dg = d.replace(gamma=float(np.sign(cls.b[0])) * gamma)
        try:
            c = fl.certify_eps(dg, cls, eps_range=er)
        except Exception as exc:  # noqa: BLE001 - a crash is reported, the run goes on
            print(f"  FAIL: certify_eps raised {type(exc).__module__}.{type(exc).__name__}: "
                  f"{exc} (gamma = {gamma!r})")
            CRASHES.append(f"certify_eps at gamma {gamma!r}: {type(exc).__name__}")
            return out
        if c.eps_star_certified is not None and np.isfinite(c.eps_star_certified):
            br = c.bracket(c.covers)
            ref = None if br is None or br.refuted is None else float(br.refuted)
            out.append(("certify_eps", c.covers, float(c.eps_star_certified),
                        c.class_description, ref, c.plant_class))
    return out


def _gain_targets(d, cls, gains, er, full, name=""):
    """``[(gamma, targets)]`` of the gains attacked: full mode :data:`GAIN_INDEX` ``full``
    (all three), quick mode the first of ``quick`` with a certified eps*; either way, when
    none of those is certified, the first certified gain of the 12."""
    order = GAIN_INDEX["full"] if full else (QUICK_INDEX.get(name, GAIN_INDEX["quick"][0]),)
    out = []
    for i in list(order) + [k for k in range(len(gains)) if k not in order]:
        if i not in order and out:
            break
        g = float(gains[i])
        tg = targets(d, cls, g, er, full)
        if tg:
            out.append((g, tg))
            if not full:
                break
    return out


def run(names, full: bool, seed: int) -> bool:
    """Attack each class; print a table; True when no attack beats a certificate."""
    rng = np.random.default_rng(seed)
    ok = True
    for name in names:
        rho, T, decay, kw = CURVE_CLASSES[name]
        cls, d, gains, er = class_and_design(rho, T, decay, kw)
        t0 = time.process_time()
        print(f"class {name!r} ({cls.describe()})", flush=True)
        best, attacked = {}, []
        for g, tg in _gain_targets(d, cls, gains, er, full, name):
            attacked.append(f"{g:.4g}")
            for src, covers, e_star, described, refuted, named in tg:
                diff = agreement(d, cls, e_star, g)
                if not diff < 1e-9:
                    print(f"  FAIL: this loop and the library's disagree at gamma = {g:.4g}, "
                          f"eps = {e_star:.4g}: trace(M^j) differ by {diff:.2e} (relative)")
                    ok = False
                for frac in FRACTIONS:
                    res = attack_target(d, cls, frac * e_star, g, covers, rng, full, named)
                    for group in ("stated coverage", "named class"):
                        r = res[group]
                        key = (src, covers, group)
                        if r["growth"] > best.get(key, (-np.inf,))[0]:
                            where = f"{r['attack']} at gamma {g:.4g}, {frac:g} eps*"
                            best[key] = (r["growth"], where, r["beat"])
                        elif r["beat"]:
                            best[key] = best[key][:2] + (True,)
                        print(f"  gamma {g:.4g}, {src} eps* = {e_star:.5g} (covers {covers}), "
                              f"attacked at {frac:g} eps*: {group}: best growth "
                              f"{r['growth']:.12f} ({r['attack']}; traj. x{r['traj']:.3g}), "
                              f"margin {1 - r['growth']:.3g}"
                              + (" -> BEATS" if r["beat"] else "")
                              + (" (trajectory > 10x without a growing product: a non-normal "
                                 "transient)" if r["transient"] else ""), flush=True)
                        if r["beat"]:
                            ok = False
                            print(f"    BEATEN: {src} certifies eps* = {e_star:.6g} for "
                                  f"'{described}' (covers {covers}); member sequence "
                                  f"{r['witness']}")
                if refuted is not None:  # control: the attacks find the library's own refutation
                    r = attack_target(d, cls, refuted, g, covers, rng, full)["stated coverage"]
                    print(f"  control: at the refuted end of certify_eps's bracket, eps = "
                          f"{refuted:.5g} ({refuted / e_star:.3g} eps*): best growth "
                          f"{r['growth']:.12f} ({r['attack']}): the attacks "
                          + ("find it" if r["beat"] else "do NOT find it"), flush=True)
        if not attacked:
            print(f"  => {name}: no certified gain to attack")
            continue
        parts = [f"{src} (covers {cov}) vs {grp}: growth {v[0]:.12f} ({v[1]}), margin "
                 f"{1 - v[0]:.3g}{' BEATEN' if v[2] else ''}"
                 for (src, cov, grp), v in best.items()]
        print(f"  => {name}: gains attacked {attacked}; " + "; ".join(parts)
              + f"; CPU {time.process_time() - t0:.1f} s", flush=True)
    return ok


def main(argv=None) -> int:
    """Run the attacks; return the exit status."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help="one gain, the curve's eps* only, shorter attacks (the tests)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random sequences")
    p.add_argument("--only", nargs="*", default=None, help="these classes of CURVE_CLASSES")
    args = p.parse_args(argv)
    names = args.only or list(CURVE_CLASSES)
    bad = [n for n in names if n not in CURVE_CLASSES]
    if bad:
        print(f"unknown class(es) {bad}; valid: {list(CURVE_CLASSES)}")
        return 2
    print(f"seed {args.seed}; growth confirmed in mpmath above 1 + {CONFIRM:g}; "
          f"{load_line()}")
    ok = run(names, not args.quick, args.seed)
    if CRASHES:
        print(f"FAIL: {len(CRASHES)} certificate call(s) raised: {'; '.join(CRASHES)}")
        ok = False
    print("no attack beats a certificate" if ok else "FAIL: an attack beats a certificate")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
