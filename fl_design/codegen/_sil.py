"""Software-in-the-loop check of a generated package against ``Design.step``.

The compiled ``<prefix>_step`` drives the simulated plant in closed loop: a C driver
(``templates/sil.c.in``) links the package with CasADi's code of the plant's RK4 step
(:attr:`fl_design.sim.ClosedLoop.plant_step`, in double) and output ``h``, and runs the
scenario's samples (reference, noise, quantization) ``ym_k -> u_k -> x_(k+1)``. The
measurements ``ym`` it saw are then fed to the design's own step in CasADi's interpreter
(:meth:`fl_design.Design.run`, the user's design, not the generated one) and the two input
sequences are compared.

Bounds: double within ``1e-12`` of ``max |u|``. Float (:data:`FLOAT_BOUND`): within ``1e-4`` of
``max |u|``: the float step rounds the measurement (``ulp(y) ~ 3e-8`` at ``y ~ 0.3``) and its
own arithmetic to 24 bits, and the closed loop keeps that error from accumulating; the error
of the last tenth of the run is reported and checked against the same bound (no drift).

Examples
--------
>>> from fl_design.codegen._sil import bound_for
>>> bound_for("double"), bound_for("float")
(1e-12, 0.0001)
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources

import casadi as ca
import numpy as np

from ..sim import ClosedLoop
from ..sim.kernel._loop import default_substeps
from ._package import compiler_or_raise, run_command
from ._template import render

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
    >>> from fl_design.codegen._sil import bound_for
    >>> bound_for("float") > bound_for("double")
    True
    """
    return FLOAT_BOUND if precision == "float" else DOUBLE_BOUND


@dataclass(frozen=True)
class SilResult:
    """The compiled step in closed loop versus ``Design.step`` on the same measurements.

    Parameters
    ----------
    precision : str
        Of the package.
    ym : numpy.ndarray
        ``(N,)`` measurements the C step received.
    u_c : numpy.ndarray
        ``(N,)`` inputs of the compiled step (applied to the plant).
    u_ref : numpy.ndarray
        ``(N,)`` inputs of ``design.step`` fed ``ym``.
    bound : float
        Relative bound (fraction of ``max |u_ref|``).

    Attributes
    ----------
    max_abs_error, max_rel_error, tail_rel_error : float
        ``max |u_c - u_ref|``, divided by ``max |u_ref|``, and the latter over the last tenth.
    passed : bool
        Both relative errors within ``bound``.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.codegen import SilResult
    >>> r = SilResult("double", np.zeros(2), np.array([1.0, 2.0]), np.array([1.0, 2.0]), 1e-12)
    >>> r.passed, r.to_dict()["max_rel_error"]
    (True, 0.0)
    """

    precision: str
    ym: np.ndarray
    u_c: np.ndarray
    u_ref: np.ndarray
    bound: float

    @property
    def max_abs_error(self) -> float:
        """``max |u_c - u_ref|``."""
        return float(np.max(np.abs(self.u_c - self.u_ref)))

    @property
    def _scale(self) -> float:
        return max(float(np.max(np.abs(self.u_ref))), np.finfo(float).tiny)

    @property
    def max_rel_error(self) -> float:
        """``max |u_c - u_ref| / max |u_ref|``."""
        return self.max_abs_error / self._scale

    @property
    def tail_rel_error(self) -> float:
        """The relative error over the last tenth of the run (drift check)."""
        k = max(1, self.u_c.size // 10)
        return float(np.max(np.abs(self.u_c[-k:] - self.u_ref[-k:]))) / self._scale

    @property
    def passed(self) -> bool:
        """Within the bound, over the run and over its last tenth."""
        return bool(self.max_rel_error <= self.bound and self.tail_rel_error <= self.bound)

    def to_dict(self) -> dict:
        """Strict-JSON summary (no sample arrays).

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.codegen import SilResult
        >>> sorted(SilResult("float", np.zeros(1), np.ones(1), np.ones(1), 1e-4).to_dict())
        ['bound', 'max_abs_error', 'max_rel_error', 'n_samples', 'passed', 'precision', 'tail_rel_error']
        """
        return {"precision": self.precision, "n_samples": int(self.u_c.size),
                "max_abs_error": self.max_abs_error, "max_rel_error": self.max_rel_error,
                "tail_rel_error": self.tail_rel_error, "bound": float(self.bound),
                "passed": self.passed}


def _plant_code(loop: ClosedLoop, prefix: str, build) -> tuple:
    x, u = ca.SX.sym("x", loop.n), ca.SX.sym("u")
    rk4 = ca.Function(f"{prefix}_sil_rk4", [x, u], [loop.plant_step(x, u)])
    h = ca.Function(f"{prefix}_sil_h", [x], [loop.plant.casadi().h(x)])
    cg = ca.CodeGenerator(f"{prefix}_plant.c", {"with_header": True, "casadi_int": "int",
                                                "with_export": False, "verbose": False})
    cg.add(rk4)
    cg.add(h)
    cg.generate(str(build) + "/")
    return build / f"{prefix}_plant.c"


def build_driver(pkg, plant, substeps: int, compiler=None):
    """Compile the closed-loop driver of ``pkg`` with ``plant``; the executable's path.

    Parameters
    ----------
    pkg : CPackage
        The package.
    plant : Plant
        The plant.
    substeps : int
        RK4 steps per sample.
    compiler : str, optional
        C compiler.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design import presets
    >>> from fl_design.codegen._sil import build_driver
    >>> pkg = fl.generate_c(presets.paper_design(), "sil_doc")
    >>> build_driver(pkg, fl.plants.trms_yaw(), 1).name
    'fl_sil'
    """
    cc = compiler_or_raise(compiler)
    loop = ClosedLoop(plant, pkg.design, substeps=substeps)
    build = pkg.out_dir / "build"
    build.mkdir(exist_ok=True)
    plant_c = _plant_code(loop, pkg.prefix, build)
    text = resources.files("fl_design.codegen").joinpath("templates", "sil.c.in").read_text()
    driver = build / "sil.c"
    driver.write_text(render(text, {"PREFIX": pkg.prefix, "REAL": pkg.precision,
                                    "N_PLANT": str(loop.n)}))
    exe = build / f"{pkg.prefix}_sil"
    run_command([cc, "-O2", "-std=c99", f"-I{pkg.out_dir}", f"-I{build}", "-o", str(exe),
                 str(driver), str(plant_c), *map(str, pkg.sources), "-lm"],
                what="compiling the software-in-the-loop driver")
    return exe


def reference_inputs(design, ym, r, *, chunk: int = 100_000) -> np.ndarray:
    """The inputs of ``design.step`` (CasADi's interpreter) fed ``ym, r`` from the initial state.

    ``design.step`` is accumulated over chunks of samples (``mapaccum``), the state carried
    from chunk to chunk: linear in the number of samples (about 4 us per sample).

    Parameters
    ----------
    design : Design
        The design.
    ym, r : numpy.ndarray
        ``(N,)`` measurements and references.
    chunk : int, optional
        Samples per ``mapaccum``.

    Returns
    -------
    numpy.ndarray
        ``(N,)``.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design import presets
    >>> from fl_design.codegen._sil import reference_inputs
    >>> d = presets.paper_design()
    >>> y, r = np.linspace(0, 0.1, 7), np.full(7, 0.3)
    >>> np.allclose(reference_inputs(d, y, r, chunk=3), d.run(y, r).u, rtol=0, atol=1e-15)
    True
    """
    state, out = design.initial_state(), []
    for start in range(0, len(ym), chunk):
        y_c, r_c = ym[start:start + chunk], r[start:start + chunk]
        states, u = design.step.mapaccum("fl_ref", y_c.size)(state, y_c[None, :], r_c[None, :])
        states = np.asarray(states, dtype=float)
        state = states[:, -1]
        out.append(np.asarray(u, dtype=float).ravel())
    return np.concatenate(out)


def software_in_the_loop(pkg, plant, scenario, *, substeps=None, compiler=None) -> SilResult:
    """Run ``pkg``'s compiled step in closed loop with ``plant``; compare with ``Design.step``.

    Parameters
    ----------
    pkg : CPackage
        The generated package.
    plant : Plant
        The plant, integrated with RK4 (``ClosedLoop.plant_step``) in double.
    scenario : Scenario
        Reference, duration, ``x0`` (default the operating point), noise, quantization.
    substeps : int, optional
        RK4 steps per sample (default :func:`fl_design.sim.default_substeps`).
    compiler : str, optional
        C compiler.

    Returns
    -------
    SilResult

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design import presets
    >>> from fl_design.codegen import software_in_the_loop
    >>> pkg = fl.generate_c(presets.paper_design(), "sil_doc2", precision="float")
    >>> software_in_the_loop(pkg, fl.plants.trms_yaw(), fl.Scenario(0.3, 0.3)).passed
    True
    """
    design = pkg.design
    steps = default_substeps(plant, design.T) if substeps is None else int(substeps)
    exe = build_driver(pkg, plant, steps, compiler)
    N = scenario.n_samples(design.T)
    r = scenario.reference_samples(design.T)
    w = scenario.noise.samples(N)
    x0 = plant.x_op if scenario.x0 is None else np.asarray(scenario.x0, dtype=float)
    q = 0.0 if scenario.quantization is None else float(scenario.quantization)
    head = " ".join(repr(float(v)) for v in x0) + f" {q!r}\n"
    body = "\n".join(f"{a!r} {b!r}" for a, b in zip(r.tolist(), w.tolist()))
    out = np.array(run_command([str(exe)], stdin=head + body + "\n", what="the SIL driver")
                   .split(), dtype=float).reshape(-1, 2)
    ym, u_c = out[:, 0], out[:, 1]
    u_ref = reference_inputs(design, ym, r)
    return SilResult(pkg.precision, ym, u_c, u_ref, bound_for(pkg.precision))


__all__ = ["DOUBLE_BOUND", "FLOAT_BOUND", "SilResult", "bound_for", "build_driver",
           "reference_inputs",
           "software_in_the_loop"]
