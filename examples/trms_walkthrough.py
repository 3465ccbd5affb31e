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
# # The TRMS yaw walk-through
#
# The paper's experiment in simulation: derive the Twin Rotor MIMO System's yaw model, simulate
# the paper's EHGO design (`eps = 0.05`, `gamma = 3e-4`, `T = 1 ms`) and the least-squares
# baselines LS(9) and LS(26) under the same controller, with and without sensor noise.
#
# Set `FL_DESIGN_QUICK=1` in the environment for short runs (what the tests do).

# %%
import os

import matplotlib.pyplot as plt
from IPython.display import display

import fl_design as fl

QUICK = os.environ.get("FL_DESIGN_QUICK", "") not in ("", "0")
DURATION = 10.0 if QUICK else 30.0  # s
NOISE_STD = 1e-3  # rad, sensor noise of the noisy runs
print(f"runs of {DURATION:g} s" + (" (quick mode)" if QUICK else ""))

# %% [markdown]
# ## The plant and its derivation
#
# Relative degree, the normal form `sigma = a + b u`, the range of `b` over the declared region
# and input range, the zero dynamics and the residual orders of the sampled model.

# %%
plant = fl.plants.trms_yaw()
print(fl.app.derivation_report(plant))

# %% [markdown]
# ## The designs
#
# One controller for every estimator (`K = (2, 4)`, `gamma = 3e-4`, `k_I = 1e-3`); the
# estimators differ: the EHGO of the paper and the least-squares fits over 9 and 26 samples.

# %%
designs = {
    "EHGO eps=0.05": fl.presets.paper_design(eps=0.05, gamma=3e-4),
    "LS(9)": fl.presets.least_squares_design(9),
    "LS(26)": fl.presets.least_squares_design(26),
}
for name, design in designs.items():
    print(f"{name:<15} {design.estimator.flops_per_step:4d} flops per step")

# %% [markdown]
# ## Step responses, 0.3 rad step
#
# Every design without noise and with a sensor noise of standard deviation 1e-3 rad. The verdict
# says what each run shows (converged, converging, oscillating, undecided or diverged) with its
# numbers.

# %%
responses = {}
for noise_std in (0.0, NOISE_STD):
    scenario = fl.Scenario(fl.presets.PAPER_STEP, DURATION, noise=fl.Noise(std=noise_std, seed=1))
    for name, design in designs.items():
        resp = fl.simulate(plant, design, scenario)
        responses[name, noise_std] = resp
        print(f"{name:<15} noise std {noise_std:<6g} {resp.verdict()}")

# %%
fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
for ax, noise_std in zip(axes, (0.0, NOISE_STD)):
    for name in designs:
        resp = responses[name, noise_std]
        ax.plot(resp.t, resp.y, label=f"{name} ({resp.overshoot:.0f} % overshoot)")
    ax.plot(resp.t, resp.r, "k--", lw=1, label="reference")
    ax.set_xlabel("time t [s]")
    ax.set_title(f"sensor noise std {noise_std:g} rad")
    ax.legend(fontsize=8)
axes[0].set_ylabel("yaw angle y [rad]")
fig.suptitle("TRMS yaw: the paper's design (EHGO eps = 0.05, gamma = 3e-4) and LS(9), LS(26)")
fig.tight_layout()
display(fig)
plt.close(fig)

# %% [markdown]
# ## One run in detail
#
# Output, input and the estimate of `sigma` of the paper's design with noise.

# %%
resp = responses["EHGO eps=0.05", NOISE_STD]
fig = resp.plot(title="EHGO eps = 0.05, gamma = 3e-4, noise std 1e-3 rad")
display(fig)
plt.close(fig)

# %%
display(resp)
