"""The notebooks in ``examples/`` run top to bottom in quick mode and match their ``# %%`` scripts.

Each ``.ipynb`` is executed with nbclient in a fresh ``python3`` kernel (``FL_DESIGN_QUICK=1``,
``PYTHONPATH`` pointing at this checkout); no cell may error and the text outputs must contain
what the notebook is there to show. The ``.ipynb`` and its paired ``.py`` must hold the same
cells (edit one, then ``jupytext --sync examples/NAME.ipynb``).
"""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import pytest

nbclient = pytest.importorskip("nbclient")
nbformat = pytest.importorskip("nbformat")
jupytext = pytest.importorskip("jupytext")
pytest.importorskip("ipykernel")

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"

#: notebook -> regular expressions its text outputs must match
MARKERS = {
    "trms_walkthrough": [
        r"relative degree rho = 2",
        r"b-range over the region: \[3\.6, 6\.8\]",
        r"EHGO eps=0\.05 +noise std 0 +(converged|converging|oscillating|stalled|undecided)",
        r"LS\(9\) +noise std 0\.001 +(converged|converging|oscillating|stalled|undecided|diverged)",
        r"LS\(26\) +noise std 0\.001 +(converged|converging|oscillating|stalled|undecided|diverged)",
        r"Response\(N=10000, T=0\.001, status=",
        r"<th[^>]*>verdict</th><td[^>]*>(converged|converging|oscillating|stalled|undecided)",
    ],
    "pendulum_map": [
        r"relative degree 2",
        r"EpsCertificate",
        r"empirical eps\* at gamma = 0\.01: 0\.0\d+ \(fails at 0\.\d+\)",
        r"gamma +certified eps\* +frozen eps\* +linearized eps\*",
        r"0\.01 +0\.04\d* +0\.04\d* +0\.04\d*",
        r"<th[^>]*>grid</th><td[^>]*>7 eps in \[0\.002, 0\.5\] x 7 gamma",
    ],
    "robustness": [
        r"nominal plant: converged; disturbance response \{'disturbance_at': 10\.0",
        r"64 plants \(c, b\): [\d.]+% converged",
        r"recovery time: median 3\.\d+ s",
        r"sample (\d+) again with fl\.simulate: (\w+) \(Monte Carlo: \2\)",
        r"gamma = 0\.01: robust eps\* 0\.0\d+ \(fails at 0\.0\d+\)",
    ],
    "own_plant_to_c": [
        r"relative degree 2",
        r"b = 1/\(l\*\*2\*m\)",
        r"equilibrium input u_eq = 0\.94\d*",
        r"converged: \|e\| <= 0\.002 from t = ",
        r"SIL passed",
        r"\| design \| precision \| flops \| mul \| add \|",
        r"\| EHGO my_pendulum \| float \| \d+ \|",
    ],
}


def _text_outputs(nb) -> tuple[str, int]:
    """All stream, text/plain and text/html outputs joined, and the number of images shown."""
    parts, images = [], 0
    for cell in nb.cells:
        for out in cell.get("outputs", []):
            if out["output_type"] == "stream":
                parts.append(out["text"])
            elif out["output_type"] in ("execute_result", "display_data"):
                parts.append(out["data"].get("text/plain", ""))
                parts.append(out["data"].get("text/html", ""))
                images += "image/png" in out["data"]
    return "\n".join(parts), images


def _code_cells(cells) -> list[str]:
    return [c.source.strip() for c in cells if c.cell_type == "code"]


@pytest.mark.parametrize("name", sorted(MARKERS))
def test_notebook_matches_its_script(name):
    ipynb = jupytext.read(EXAMPLES / f"{name}.ipynb")
    script = jupytext.read(EXAMPLES / f"{name}.py")
    assert _code_cells(ipynb.cells) == _code_cells(script.cells)
    assert ([c.source.strip() for c in ipynb.cells if c.cell_type == "markdown"]
            == [c.source.strip() for c in script.cells if c.cell_type == "markdown"])
    raw = nbformat.read(EXAMPLES / f"{name}.ipynb", as_version=4)
    assert all(not c.get("outputs") for c in raw.cells if c.cell_type == "code"), \
        "commit notebooks with outputs stripped"


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(MARKERS))
def test_notebook_runs(name, tmp_path):
    if name == "own_plant_to_c" and not (shutil.which("gcc") or shutil.which("cc")):
        pytest.skip("no C compiler")
    nb = nbformat.read(EXAMPLES / f"{name}.ipynb", as_version=4)
    env = dict(os.environ, FL_DESIGN_QUICK="1",
               MPLBACKEND="module://matplotlib_inline.backend_inline",
               PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    client = nbclient.NotebookClient(nb, timeout=120, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute(env=env)  # keyword arguments go to the kernel manager
    errors = [o for c in nb.cells for o in c.get("outputs", []) if o["output_type"] == "error"]
    assert not errors
    text, images = _text_outputs(nb)
    for marker in MARKERS[name]:
        assert re.search(marker, text), f"{name}: no output matches {marker!r}"
    n_figures = sum(bool(re.search(r"^display\(fig\)$", c.source, re.MULTILINE)) for c in nb.cells
                    if c.cell_type == "code")
    assert images == n_figures, f"{name}: {images} images for {n_figures} figures"


def test_results_render_as_html_tables():
    import numpy as np

    import fl_design as fl
    from fl_design.sim import StabilityMap

    resp = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 0.5))
    html = resp._repr_html_()
    assert html.startswith("<table>") and f">{resp.status}<" in html
    assert "&gt;" in html or ">" not in resp.verdict()  # the verdict is escaped
    smap = StabilityMap(eps=np.array([0.01, 0.02]), gamma=np.array([1e-3]),
                        status=np.array([[2], [-1]]), metrics={}, T=1e-3, duration=1.0, tol=1e-3)
    html = smap._repr_html_()
    assert ">converged</th><td style='text-align:left'>1 runs<" in html
    assert ">diverged</th><td style='text-align:left'>1 runs<" in html
