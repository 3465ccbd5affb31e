# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # The pendulum's eps-gamma stability map and its certificate
#
# For the library's damped pendulum `theta'' = -9.81 sin(theta) - 0.5 theta' + u` and the bench
# design `fl.presets.pendulum_design()` (EHGO with all poles at `-1/eps`, `T = 1 ms`), this
# notebook sweeps the observer time constant `eps` and the controller gain `gamma`, and overlays
# the largest stable `eps` three ways: measured (the map), certified (an LMI over the range of
# `b`) and linearized (the spectral radius of the loop linearized at the equilibrium).
#
# Set `FL_DESIGN_QUICK=1` in the environment for a small grid (what the tests do).

# %%
import os

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import display

import fl_design as fl

QUICK = os.environ.get("FL_DESIGN_QUICK", "") not in ("", "0")
N_GRID = 7 if QUICK else 19  # points per axis; gamma = 1e-2 is on both grids
DURATION = 5.0 if QUICK else 15.0  # s per run
N_CURVE = 4 if QUICK else 10  # gains of the certified and linearized curves

plant = fl.plants.pendulum()
design = fl.presets.pendulum_design(eps=0.02, gamma=1e-2)
print(plant)
print("relative degree", plant.relative_degree(), "; b over the region:", plant.b_bounds())

# %% [markdown]
# ## The certificate at the design point
#
# `certify_eps` proves the sampled loop stable for every `b` in `b_bounds` (a common quadratic
# Lyapunov function) and reports the certified and frozen `eps*` at the design's `gamma`.

# %%
cert = fl.certify_eps(design, plant.b_bounds())
display(cert)

# %% [markdown]
# ## The empirical map
#
# One closed-loop simulation of a 0.1 rad step per grid point, classified converged,
# converging, oscillating, undecided or diverged.

# %%
eps_grid = np.geomspace(2e-3, 0.5, N_GRID)
gamma_grid = np.geomspace(1e-3, 1.0, N_GRID)
smap = fl.sweep(plant, design, fl.Scenario(0.1, DURATION), eps=eps_grid, gamma=gamma_grid,
                progress=not QUICK)
print(f"empirical eps* at gamma = {design.controller.gamma:g}:",
      smap.eps_star(gamma_grid[np.argmin(abs(gamma_grid - design.controller.gamma))]))
display(smap)

# %% [markdown]
# ## Certified and linearized eps*(gamma)

# %%
curve_gammas = np.geomspace(gamma_grid[0], gamma_grid[-1], N_CURVE)
curve = fl.eps_star_curve(design, plant.b_bounds(), curve_gammas)
# `linearized_eps_star` returns a bracket (`fl.EpsStar`): stable at `lower`, unstable at
# `upper`; it prints "> 1" when the loop is stable on the whole range scanned (1e-3 to 1 s).
linearized = [fl.linearized_eps_star(plant, design, gamma=g) for g in curve_gammas]
print(f"{'gamma':>10}{'certified eps*':>16}{'frozen eps*':>13}{'linearized eps*':>17}")
for g, ec, ef, el in zip(curve_gammas, curve.eps_star_certified, curve.eps_star_frozen,
                         linearized):
    text = f"{el.value:.4g}" if el.value is not None else str(el)
    print(f"{g:>10.3g}{ec:>16.4g}{ef:>13.4g}{text:>17}")

# %%
fig = smap.plot(curves={"certified eps* (LMI)": (curve_gammas, curve.eps_star_certified),
                        "linearized eps*": (curve_gammas, linearized)})
ax = fig.axes[0]
(star,) = ax.plot(design.controller.gamma, design.estimator.eps, "k*", ms=14,
                  label="design point")
ax.legend(handles=[*ax.get_legend().legend_handles, star], fontsize="small", loc="best")
ax.set_title(f"pendulum, EHGO T = 1 ms: {N_GRID} x {N_GRID} runs of {DURATION:g} s")
display(fig)
plt.close(fig)

# %% [markdown]
# The frozen and certified curves alone (the certified one is below the frozen one: it holds
# for `b` varying in time, the frozen check only for each constant `b`).

# %%
fig = curve.plot()
display(fig)
plt.close(fig)
