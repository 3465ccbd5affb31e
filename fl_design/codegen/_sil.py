"""Software-in-the-loop check of a generated package: does the C loop work, and is it the design?

The compiled ``<prefix>_step`` drives the simulated plant in closed loop, started as firmware
starts it: ``<prefix>_init``, then ``<prefix>_start(s, ym_0, u0)`` with the first measurement
and the input ``fl.simulate`` starts from (``u_eq``, or the controller's ``u0``). A C driver
(``templates/sil.c.in``) links the package with CasADi's code of the plant's RK4 step
(:attr:`fl_design.sim.ClosedLoop.plant_step`, in double; compiled once per content,
:func:`fl_design._toolchain.build_program`) and runs the scenario's samples
(reference, noise, quantization, the scenario's disturbances). The check passes only when both
hold:

(a) **the C is the design**: the measurements the C saw, fed to ``Design.step`` of the design
    it was generated from (CasADi's interpreter, the same start state), give the same inputs
    within the precision's bound: double within ``1e-12`` of ``max |u|``; float
    (:data:`FLOAT_BOUND`) within ``1e-4`` of ``max |u|`` (24-bit rounding of ``y`` and of the
    arithmetic; the closed loop keeps it from accumulating; the last tenth of the run is checked
    against the same bound: no drift);
(b) **the C loop does what the simulation says**: its status, classified by the simulation
    layer's rules (:mod:`fl_design.codegen._verdict`), equals that of :func:`fl_design.simulate`
    on the same plant, design and scenario. A loop that diverges (or oscillates under a constant
    reference: :func:`loop_failed`), or stalls outside the band (an unreachable reference)
    in C and in Python agrees, but fails: :attr:`SilResult.passed` also needs the C loop not
    to fail. Any verdict mismatch fails (e.g. ``"undecided"`` in C where Python converges).
    A run too short to tell (``"undecided"`` in both) passes with that status in the result
    (:attr:`SilResult.c_stable` is then False): run longer, or give no duration (the run then
    chooses its length from the loop's slowest mode), to see it converge.

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

from .._cache import replace_bytes
from .._toolchain import UnusableCache, build_program
from ..errors import ComputationError, ParameterError
from ..sim import ClosedLoop, simulate
from ..sim._run import prepare_run
from ._build import compiler_or_raise, run_command
from ._compare import DOUBLE_BOUND, FLOAT_BOUND, InputComparison, bound_for, reference_run
from ._float_realize import design_states
from ._template import render
from ._verdict import c_loop_response

#: statuses of the C loop that fail the check whatever the simulation says (``"stalled"``: the
#: output stopped outside the band, e.g. an unreachable reference under the input limits)
FAILING = ("diverged", "oscillating", "solver_failed", "stalled")


def loop_failed(status: str, r_tail) -> bool:
    """Whether a C loop with ``status`` fails the check (``r_tail``: the reference's tail).

    A status in :data:`FAILING` fails (``"stalled"``, an unreachable or never-reached
    reference, included), except ``"oscillating"`` under a reference that moves in the tail
    window: the classifier counts reversals of the error, which a loop tracking a square wave
    shows too (the status then says nothing about the loop).

    Parameters
    ----------
    status : str
        The C loop's status.
    r_tail : array_like
        Reference samples of the tail window.

    Returns
    -------
    bool

    Examples
    --------
    >>> from fl_design.codegen._sil import loop_failed
    >>> loop_failed("oscillating", [0.3, 0.3]), loop_failed("oscillating", [0.3, -0.3])
    (True, False)
    >>> loop_failed("stalled", [1.0, 1.0]), loop_failed("undecided", [1.0, 1.0])
    (True, False)
    """
    if status == "oscillating":
        return bool(np.ptp(np.asarray(r_tail, dtype=float)) == 0.0)
    return status in FAILING


@dataclass(frozen=True)
class SilResult(InputComparison):
    """The compiled step in closed loop: its verdict, the simulation's, and its error.

    Parameters
    ----------
    precision, ym, u_c, u_ref, bound
        As in :class:`~fl_design.codegen._compare.InputComparison`: the package's precision,
        the ``(N,)`` measurements the C step received, its inputs (applied to the plant) and
        those of ``Design.step`` fed ``ym`` from the same start, the relative bound
        (fraction of ``max |u_ref|``).
    c_status : str, optional
        Status of the C loop (``"converged"``, ``"diverged"``...; :data:`fl_design.sim.STATUS_NAMES`).
    sim_status : str, optional
        Status of :func:`fl_design.simulate` on the same run.
    c_stable : bool, optional
        The C loop's status is convergent (``"converged"`` or ``"converging"``).
    c_failed : bool, optional
        The C loop failed (:func:`loop_failed`: diverged, solver failed, stalled outside the
        band, or oscillating under a constant reference).

    Attributes
    ----------
    max_abs_error, max_rel_error, tail_rel_error, matches
        Of :class:`~fl_design.codegen._compare.InputComparison` (over the samples before a
        divergence, if any).
    verdicts_agree : bool
        ``c_status == sim_status``.
    passed : bool
        ``matches`` and ``verdicts_agree`` and not ``c_failed``.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.codegen import SilResult
    >>> r = SilResult("double", np.zeros(2), np.array([1.0, 2.0]), np.array([1.0, 2.0]), 1e-12,
    ...               "converged", "converged", True, False)
    >>> r.passed, r.to_dict()["max_rel_error"]
    (True, 0.0)
    """

    c_status: str = "undecided"
    sim_status: str = "undecided"
    c_stable: bool = False
    c_failed: bool = False

    @property
    def verdicts_agree(self) -> bool:
        """The C loop's status equals :func:`fl_design.simulate`'s."""
        return self.c_status == self.sim_status

    @property
    def passed(self) -> bool:
        """The C matches the design, the verdicts agree, and the C loop does not fail."""
        return bool(self.matches and self.verdicts_agree and not self.c_failed)

    def to_dict(self) -> dict:
        """Strict-JSON summary (no sample arrays).

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.codegen import SilResult
        >>> d = SilResult("float", np.zeros(1), np.ones(1), np.ones(1), 1e-4).to_dict()
        >>> d["passed"], d["c_status"], d["c_stable"]
        (True, 'undecided', False)
        """
        return {**self.errors(), "c_status": self.c_status, "sim_status": self.sim_status,
                "verdicts_agree": self.verdicts_agree, "c_stable": bool(self.c_stable),
                "c_failed": bool(self.c_failed), "passed": self.passed}


def _plant_code(loop: ClosedLoop, prefix: str, build) -> tuple:
    """CasADi's C of the plant's RK4 sample and output map; (path, work sizes for the driver).

    The driver passes real ``arg/res/iw/w`` arrays sized from the functions' own ``sz_*``
    (at least 1 each): with more than one substep the RK4 sample is a ``fold`` whose code
    uses them (passing null work pointers crashed the driver).
    """
    x, u = ca.SX.sym("x", loop.n), ca.SX.sym("u")
    rk4 = ca.Function(f"{prefix}_sil_rk4", [x, u], [loop.plant_step(x, u)])
    h = ca.Function(f"{prefix}_sil_h", [x], [loop.plant.casadi().h(x)])
    cg = ca.CodeGenerator(f"{prefix}_plant.c", {"with_header": True, "casadi_int": "int",
                                                "with_export": False, "verbose": False})
    cg.add(rk4)
    cg.add(h)
    cg.generate(str(build) + "/")
    sizes = {f"SZ_{k.upper()}": str(max(1, getattr(rk4, f"sz_{k}")(), getattr(h, f"sz_{k}")()))
             for k in ("arg", "res", "iw", "w")}
    return build / f"{prefix}_plant.c", sizes


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
    plant_c, work_sizes = _plant_code(loop, pkg.prefix, build)
    text = resources.files("fl_design.codegen").joinpath("templates", "sil.c.in").read_text()
    driver = build / "sil.c"
    driver.write_text(render(text, {"PREFIX": pkg.prefix, "REAL": pkg.precision,
                                    "N_PLANT": str(loop.n), **work_sizes}))
    # the same units, in the same order, at -O2 as the package's own build; compiled once per
    # content (a warm job's SIL reuses it: 0.33 s of compiler CPU, 15 % of the quick warm job)
    units = {f"{pkg.prefix}_sil_main.c": driver.read_text(), plant_c.name: plant_c.read_text(),
             **{src.name: src.read_text() for src in pkg.sources}}
    headers = {h.name: h.read_text() for h in (*sorted(pkg.out_dir.glob("*.h")),
                                               plant_c.with_suffix(".h"))}
    exe = build / f"{pkg.prefix}_sil"
    try:
        data = build_program({**units, **headers}, f"{pkg.prefix}_sil",
                             flags=["-O2", "-std=c99", "-I."], compiler=cc)
    except UnusableCache:  # no cache and no temporary folder: compile here, uncached
        run_command([cc, "-O2", "-std=c99", f"-I{pkg.out_dir}", f"-I{build}", "-o", str(exe),
                     str(driver), str(plant_c), *map(str, pkg.sources), "-lm"],
                    what="compiling the software-in-the-loop driver")
        return exe
    replace_bytes(exe, data, mode=0o755)
    return exe


def _options(pkg, scenario, telemetry, excitation):
    """The driver's arguments, and the scenario (its reference the excitation's, if any)."""
    from dataclasses import replace

    from ..sim import Scenario
    from ._telemetry import EXCITATION_KINDS, excitation_sequence

    args = [] if telemetry is None else ["telemetry", str(telemetry)]
    if excitation is None:
        return args, scenario
    if not isinstance(scenario, Scenario) or scenario.duration is None:
        raise ParameterError("an excitation needs a scenario with a duration (the run's "
                             "length)")
    kind, center, amplitude, hold = excitation
    n = round(scenario.duration / pkg.design.T)
    ref = excitation_sequence(kind, float(center), float(amplitude), int(hold), n)
    g = pkg.guard
    if g is not None and not (g.y_min <= center - amplitude and center + amplitude <= g.y_max):
        raise ParameterError(f"excitation {center} +- {amplitude} leaves the plausibility range "
                             f"[{g.y_min:g}, {g.y_max:g}] (PREFIX_excitation_init refuses it)")
    if pkg.precision == "float":
        ref = ref.astype(np.float32).astype(float)
    args += ["excite", str(EXCITATION_KINDS[kind]), repr(float(center)), repr(float(amplitude)),
             str(int(hold))]
    return args, replace(scenario, reference=ref, duration=n * pkg.design.T)


def software_in_the_loop(pkg, plant, scenario, *, integrator=None, compiler=None,
                         telemetry=None, excitation=None) -> SilResult:
    """Run ``pkg``'s compiled step in closed loop with ``plant``, started as firmware starts it.

    See the module docstring: passes when the C equals ``Design.step`` within the precision's
    bound, its loop's status equals :func:`fl_design.simulate`'s, and it converges.

    Parameters
    ----------
    pkg : CPackage
        The generated package.
    plant : Plant
        The plant, integrated with RK4 (``ClosedLoop.plant_step``) in double.
    scenario : Scenario
        Reference, duration, ``x0`` (default the operating point), noise, quantization. An
        ``initial_estimate`` is refused (firmware starts from a measurement).
    integrator : RK4, optional
        The plant's fixed-step integrator between samples (default ``fl.RK4()``:
        :func:`fl_design.sim.kernel.default_substeps` steps), in the C driver and the
        simulation alike.
    compiler : str, optional
        C compiler.
    telemetry : path-like, optional
        Write the C loop's telemetry frames there (``PREFIX_telemetry`` after each step;
        :func:`fl_design.read_telemetry` reads them).
    excitation : tuple, optional
        ``(kind, center, amplitude, hold)``: the reference is the firmware's
        ``PREFIX_excite`` (:func:`~fl_design.codegen._telemetry.excitation_sequence`), in
        the C loop and in the simulation it is compared with, over the scenario's duration
        (which must be given).

    Returns
    -------
    SilResult

    Raises
    ------
    ParameterError
        A q31 package; ``scenario.initial_estimate`` is set; ``integrator`` not a
        ``fl.RK4``; an excitation
        without a duration, or one the C refuses (outside the plausibility range).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design import presets
    >>> from fl_design.codegen import software_in_the_loop
    >>> pkg = fl.generate_c(presets.maglev_design(), "sil_doc2", precision="float")
    >>> res = software_in_the_loop(pkg, fl.plants.maglev(), fl.Scenario(6.2e-3, 2.0))
    >>> res.passed, res.c_status, res.sim_status, res.max_rel_error < 1e-4
    (True, 'converged', 'converged', True)
    """
    from ..sim import RK4

    if pkg.precision == "q31":
        raise ParameterError(
            "software_in_the_loop of a precision='q31' package is not available: its make "
            "check replays bit-exact vectors of the integer model, and "
            "CPackage.predicted_float_error is its measured error against Design.step")
    if getattr(scenario, "initial_estimate", None) is not None:
        raise ParameterError(
            "scenario.initial_estimate is set; the C loop starts as firmware does, from the "
            "first measurement (PREFIX_start): give a scenario without initial_estimate")
    design = pkg.design
    args, scenario = _options(pkg, scenario, telemetry, excitation)
    run = prepare_run(plant, design, scenario, integrator=integrator)
    steps = run.loop.substeps
    exe = build_driver(pkg, plant, steps, compiler)
    head = " ".join(repr(float(v)) for v in run.x0) + f" {float(run.q)!r} {run.u0!r}\n"
    body = "\n".join(f"{a!r} {b!r} {c!r}"
                     for a, b, c in zip(run.r.tolist(), run.noise.tolist(), run.d_in.tolist()))
    n = run.loop.n
    out = np.array(run_command([str(exe), *args], stdin=head + body + "\n",
                               what="the SIL driver").split(), dtype=float).reshape(-1, 4 + 2 * n)
    y, ym, u_c = out[:, 0], out[:, 1], out[:, 2]
    X, X_next = out[:, 4:4 + n], out[:, 4 + n:]
    if excitation is not None:  # the C routine made the reference the simulation was given
        tol = 1e-6 * max(1.0, float(np.max(np.abs(run.r)))) if pkg.precision == "float" else 0
        if not np.allclose(out[:, 3], run.r, rtol=0, atol=tol):
            raise ComputationError("the C excitation differs from excitation_sequence: "
                                   f"max {np.max(np.abs(out[:, 3] - run.r)):.3g}")
    used = pkg.step_design
    state0 = used.initial_state(y0=float(ym[0]), u0=run.u0)
    u_ref, xhat, states = reference_run(used, ym, run.r, state0=state0)
    states = design_states(used, states)  # the user's design's coordinates (its loop's bounds)
    c_resp = c_loop_response(run, y, ym, u_c, X, X_next, xhat, states)
    sim_resp = simulate(plant, design, run.scenario, integrator=RK4(substeps=steps))
    failed = loop_failed(c_resp.status, run.r[run.k_tail:])
    return SilResult(pkg.precision, ym, u_c, u_ref, bound_for(pkg.precision),
                     c_resp.status, sim_resp.status, bool(c_resp.stable), failed)


__all__ = ["DOUBLE_BOUND", "FAILING", "FLOAT_BOUND", "SilResult", "bound_for", "build_driver",
           "loop_failed",
           "reference_run", "software_in_the_loop"]
