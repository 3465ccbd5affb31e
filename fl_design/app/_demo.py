"""The main job on the built-in Twin Rotor example (``make demo`` / ``fl-design demo``).

The job follows a control engineer's path through the method of Shenoy et al. on the TRMS yaw
plant with the paper's numbers (``T = 1 ms``, ``eps = 0.05``, observer polynomial
``s^3 + 6 s^2 + 11 s + 6``, ``k = (2, 4)``, ``gamma = 3e-4``, ``k_I = 1e-3``, ``|xhat_2| <= 0.05``,
0.3 rad step):

1. derive: relative degree, ``a``, ``b``, b-range, residual orders;
2. choose numbers: spectral radius of the sampled linearized loop and its ``eps*``;
3. simulate the EHGO design and the least-squares baseline (windows 9 and 26) without and with
   measurement noise (variance 1e-3, as in the paper's experiment);
4. map stability over an ``(eps, gamma)`` grid;
5. write ``summary.json`` and figures to ``out_dir``.

Examples
--------
>>> from fl_design.app import run_demo
>>> run_demo.__name__
'run_demo'
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .. import plants
from .._json import dumps
from ..presets import PAPER_STEP, paper_design
from ..presets import least_squares_design as baseline_design
from ..sim import Noise, Scenario
from ._report import derivation_report

STEP = PAPER_STEP
NOISE_STD = float(np.sqrt(1e-3))  # the paper adds noise of variance 0.001 to the yaw sensor


def _row(name: str, resp, flops: int) -> dict:
    m = resp.metrics
    return {"design": name, "status": resp.status, "verdict": resp.verdict(),
            "overshoot_%": m["overshoot"],
            "settling_time_s": m["settling_time"], "iae": m["iae"], "u_rms": m["input_rms"],
            "u_total_variation": m["input_tv"], "flops_per_step": flops}


def _print_table(rows: list[dict], title: str) -> None:
    print(f"\n{title}")
    print(f"  {'design':<16}{'status':>12}{'overshoot %':>13}{'settle s':>10}{'IAE':>9}"
          f"{'u RMS':>9}{'u TV':>10}{'flops':>7}")
    for r in rows:
        print(f"  {r['design']:<16}{r['status']:>12}{r['overshoot_%']:>13.1f}"
              f"{r['settling_time_s']:>10.2f}{r['iae']:>9.3f}{r['u_rms']:>9.3f}"
              f"{r['u_total_variation']:>10.2f}{r['flops_per_step']:>7d}")


def run_demo(*, quick: bool = False, out_dir: str | Path = "out", show_progress: bool = True) -> int:
    """Run the main job; print a report and write ``summary.json`` and figures to ``out_dir``.

    Parameters
    ----------
    quick : bool, optional
        Short runs and a small grid (a few seconds; the tests use it).
    out_dir : str or pathlib.Path, optional
        Folder for ``summary.json``, ``response.png`` and ``stability_map.png``.
    show_progress : bool, optional
        Progress bar on the sweep.

    Returns
    -------
    int
        0 on success.

    Examples
    --------
    >>> run_demo(quick=True, out_dir="demo_out", show_progress=False)  # doctest: +SKIP
    0
    """
    from ..analysis._linearization import linearized_eps_star, sampled_linearization
    from ..sim._simulate import simulate
    from ..sim._sweep import sweep

    start = time.perf_counter()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    plant = plants.trms_yaw()
    print(derivation_report(plant))
    duration = 4.0 if quick else 20.0

    design = paper_design()
    lin = sampled_linearization(plant, design, r=0.0)
    eps_lin = linearized_eps_star(plant, design)
    print(f"\nSampled linearized loop at eps = {design.estimator.eps}: spectral radius "
          f"{lin.spectral_radius:.9f} ({'stable' if lin.stable else 'UNSTABLE'})")
    print(f"Linearized eps* for gamma = {design.controller.gamma} (eps in [1e-3, 1]): {eps_lin:.4g}")

    summary: dict = {"plant": plant.name, "b_bounds": list(plant.b_bounds()),
                     "spectral_radius": lin.spectral_radius, "eps_star_linearized": eps_lin}
    candidates = [("EHGO eps=0.05", design), ("LS window=9", baseline_design(9)),
                  ("LS window=26", baseline_design(26))]
    responses = {}
    for noise_std, title in ((0.0, "noise-free"), (NOISE_STD, f"noise std {NOISE_STD:.4f}")):
        rows = []
        for name, d in candidates:
            resp = simulate(plant, d, Scenario(STEP, duration, noise=Noise(std=noise_std, seed=1)))
            rows.append(_row(name, resp, d.estimator.flops_per_step))
            responses[(name, noise_std)] = resp
        _print_table(rows, f"0.3 rad step, {duration:g} s, {title}:")
        summary[title] = rows

    n_grid = 5 if quick else 17
    grid_eps = np.geomspace(0.01, 1.0, n_grid)
    grid_gamma = np.geomspace(3e-5, 3e-1, n_grid)  # contains the paper's gamma = 3e-4
    smap = sweep(plant, design, Scenario(STEP, duration), eps=grid_eps, gamma=grid_gamma,
                 progress=show_progress)
    counts = ", ".join(f"{int(np.sum(smap.labels == lab))} {lab}"
                       for lab in ("converged", "converging", "oscillating", "diverged"))
    print(f"\nStability map {grid_eps.size} x {grid_gamma.size} (eps x gamma): {counts}")
    print("  gamma       empirical eps* (grid)   linearized eps* (eps in [1e-3, 1])")
    eps_table = []
    for g in grid_gamma[::2]:
        emp = smap.eps_star(g)
        lin_star = linearized_eps_star(plant, design, gamma=float(g), eps_range=(1e-3, 1.0))
        eps_table.append({"gamma": float(g), "eps_star_empirical": emp,
                          "eps_star_linearized": lin_star})
        print(f"  {g:<10.3g}  {emp!s:<22}  {lin_star:.4g}")
    summary["eps_star_table"] = eps_table
    print("  (empirical: every grid eps' <= eps converges on the nonlinear plant (converging or "
          "converged);\n   '> x': all scanned eps converge. The TRMS friction "
          "B2 tanh(phi'/1e-3) is very stiff at rest, so the linearization there is over-damped "
          "and its eps* optimistic.)")
    summary["stability_map"] = smap.to_dict()

    fig = responses[("EHGO eps=0.05", 0.0)].plot().figure
    fig.savefig(out / "response.png", dpi=110)
    smap.plot().figure.savefig(out / "stability_map.png", dpi=110)
    (out / "summary.json").write_text(dumps(summary, indent=2))
    print(f"\nWrote {out / 'summary.json'}, response.png, stability_map.png "
          f"in {time.perf_counter() - start:.1f} s")
    return 0
