# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Is the design robust? A family of pendulums and a step disturbance
#
# The method is model-free: the observer estimates the lumped `sigma = a + b u`, so the loop
# should hold when the plant is not what the model says. This notebook checks the bench design
# `fl.presets.pendulum_design()` against a *family* of damped pendulums
# `theta'' = -9.81 sin(theta) - c theta' + b u`, damping `c ~ U(0.05, 1)` and input gain
# `b ~ N(1, 0.3)`, under a step input disturbance, with `fl.monte_carlo` (every plant is
# `plant.with_params(c=..., b=...)`, run in the compiled kernel with the parameters as run-time
# inputs) and `fl.sweep(..., params=...)` (the robust stability map).
#
# Set `FL_DESIGN_QUICK=1` in the environment for fewer plants (what the tests do).

# %%
import os

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import display

import fl_design as fl

QUICK = os.environ.get("FL_DESIGN_QUICK", "") not in ("", "0")
N = 64 if QUICK else 1000  # plants of the Monte Carlo
SAMPLES = 16 if QUICK else 64  # plants per point of the robust map

plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
params = {"c": (0.05, 1.0), "b": fl.Normal(1.0, 0.3)}
scenario = fl.Scenario(0.1, 20.0, disturbance=fl.Disturbance(input=fl.Step(at=10.0, size=0.5)))

# %% [markdown]
# ## The nominal plant
#
# A 0.1 rad step, then a 0.5 N m input step at 10 s: the estimator sees it in `sigma` and the
# controller cancels it.

# %%
resp = fl.simulate(plant, design, scenario)
print(f"nominal plant: {resp.status}; disturbance response {resp.disturbance}")

# %% [markdown]
# ## A thousand plants
#
# The same design and scenario on `N` plants drawn from the distributions (seeded: the same
# seed gives the same plants). Each run is classified as `fl.simulate` classifies it.

# %%
ens = fl.monte_carlo(plant, design, scenario, params=params, n=N, seed=0, progress=not QUICK)
print(ens)
rec = ens.metrics["recovery_time"]
print(f"recovery time: median {np.nanmedian(rec):.3g} s, largest {np.nanmax(rec):.3g} s; "
      f"largest peak deviation after the disturbance {np.nanmax(ens.metrics['disturbance_peak']):.3g} rad")
for w in ens.worst(3):
    print(f"worst: sample {w['index']}, c = {w['c']:.3g}, b = {w['b']:.3g}: {w['status']}, "
          f"tail error {w['tail_error']:.3g}")

# %% [markdown]
# One of them, simulated on its own, gives the same verdict:

# %%
i = ens.worst(1)[0]["index"]
again = fl.simulate(plant.with_params(**ens.sample(i)), design, scenario)
print(f"sample {i} again with fl.simulate: {again.status} (Monte Carlo: {ens.labels[i]})")

# %%
fig = ens.plot(metrics=("recovery_time", "disturbance_peak", "input_rms"))
display(fig)
plt.close(fig)

# %% [markdown]
# ## The robust stability map
#
# Each (eps, gamma) point is run against the same `SAMPLES` plants and coloured by the
# fraction that converges; the robust eps* is the largest eps below which every sampled plant
# converges (compare with the nominal plant's map).

# %%
eps_grid = np.geomspace(0.005, 0.1, 8 if QUICK else 16)
gamma_grid = [0.005, 0.01, 0.02]
short = fl.Scenario(0.1, 10.0)
rmap = fl.sweep(plant, design, short, eps=eps_grid, gamma=gamma_grid, params=params,
                samples=SAMPLES, progress=not QUICK)
smap = fl.sweep(plant, design, short, eps=eps_grid, gamma=gamma_grid, progress=False)
for g in gamma_grid:
    print(f"gamma = {g:g}: robust eps* {rmap.eps_star(g)}; 90 % of the plants "
          f"{rmap.eps_star(g, level=0.9)}; nominal plant {smap.eps_star(g)}")

# %%
fig = rmap.plot()
display(fig)
plt.close(fig)
