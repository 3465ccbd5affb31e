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
# # From your own SymPy plant to C code
#
# A plant written from scratch: a damped pendulum of mass `m` on a rod of length `l`, with
# viscous friction `c` and a torque input `u`, held around `theta = 0.5 rad` (an operating point
# away from rest, so the equilibrium input is not zero):
#
# `m l^2 theta'' = -m g l sin(theta) - c theta' + u`,  `y = theta`.
#
# Steps: relative degree and normal form, a design, a simulation, float C code, its
# software-in-the-loop check against the Python step and its cost table. A C compiler (`gcc` or
# `cc`) is needed for the last two. Set `FL_DESIGN_QUICK=1` for short runs (what the tests do).

# %%
import os
import tempfile

import matplotlib.pyplot as plt
import sympy as sp
from IPython.display import display

import fl_design as fl
from fl_design.codegen import CostTable

QUICK = os.environ.get("FL_DESIGN_QUICK", "") not in ("", "0")
DURATION = 15.0 if QUICK else 30.0  # s, closed-loop simulation
SIL_DURATION = 2.0 if QUICK else 60.0  # s, software-in-the-loop run
BENCH_STEPS = 20_000 if QUICK else 2_000_000  # steps of the C timing run

# %% [markdown]
# ## The plant

# %%
theta, omega, u = sp.symbols("theta omega u")
m, l, c, g = sp.symbols("m l c g", positive=True)
plant = fl.Plant.from_ode(
    states=[theta, omega],
    input=u,
    rhs=[omega, (-m * g * l * sp.sin(theta) - c * omega + u) / (m * l**2)],
    output=theta,
    params={m: 0.5, l: 0.4, c: 0.05, g: 9.81},
    name="my_pendulum",
    region={theta: (-1.5, 1.5), omega: (-8.0, 8.0)},
    input_range=(-5.0, 5.0),
    operating_point={"y": 0.5},
)
display(plant)

# %%
print("relative degree", plant.relative_degree())
nf = plant.normal_form()
print(nf)
print("a =", nf.a)
print("b =", nf.b)
print("b over the region:", plant.b_bounds(), "; equilibrium input u_eq =", plant.u_eq)

# %% [markdown]
# ## A design
#
# `b = 1/(m l^2) = 12.5` is known only through its range; the dynamic controller needs
# `gamma < 1/b_max`. EHGO with all three poles at `-1/eps`, `T = 1 ms`; controller gains
# `K = (2, 4)` (closed-loop polynomial `s^2 + 4 s + 2`).

# %%
b_max = max(abs(b) for b in plant.b_bounds())
gamma = 0.01 / b_max
design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
                   controller=fl.DynamicController(gains=(2.0, 4.0), gamma=gamma,
                                                   u_limits=(-5.0, 5.0)))
print(design)
cert = fl.certify_eps(design, plant.b_bounds())
print("certified eps*:", cert.eps_star_certified, "(design eps = 0.02)")

# %% [markdown]
# ## Simulation: a 0.1 rad step from the operating point, with sensor noise

# %%
scenario = fl.Scenario(0.6, DURATION, noise=fl.Noise(std=1e-4, seed=1))
resp = fl.simulate(plant, design, scenario)
print(resp.verdict())
fig = resp.plot(title=f"my_pendulum: EHGO eps = 0.02, gamma = {gamma:.3g}")
display(fig)
plt.close(fig)

# %% [markdown]
# ## Float C code, software in the loop, cost

# %%
out_dir = tempfile.mkdtemp(prefix="fl_c_")
pkg = fl.generate_c(design, out_dir, precision="float")
print("files:", ", ".join(sorted(p.name for p in map(__import__("pathlib").Path, pkg.files))))

# %%
sil = pkg.verify(plant, fl.Scenario(0.6, SIL_DURATION, noise=fl.Noise(std=1e-4, seed=2)))
print(f"SIL {'passed' if sil.passed else 'FAILED'}: max |u_C - u_python| / max |u| = "
      f"{sil.max_rel_error:.2e} (bound {sil.bound:g}), last tenth {sil.tail_rel_error:.2e}")

# %%
table = CostTable((pkg.cost(name="EHGO my_pendulum", bench_steps=BENCH_STEPS),))
print(table.to_markdown())
