"""Processor-in-the-loop: the package's step on a Cortex-M4F model (QEMU ``mps2-an386``).

:func:`processor_in_the_loop` records the measurements of :func:`fl_design.simulate` on the
user's plant and scenario, writes them into ``pil_data.h``, cross-compiles the package with the
shipped start-up file and linker script (``pil/`` in the package) for ``-mcpu=cortex-m4
-mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16`` (the package sources with the strict flags), runs it
under ``qemu-system-arm -M mps2-an386 -icount shift=0`` (one instruction per nanosecond of
virtual time; SysTick, at the board's clock, ticks every few tens of instructions, so the
steps are timed in blocks of 256 against the same loop calling an empty function; QEMU is
not cycle-accurate, so the cost is reported in instructions per step, not time), and compares the inputs ``u`` it prints (bit patterns, via
semihosting) with ``Design.step`` fed the same measurements from the same start, within the
precision's bound of :mod:`fl_design.codegen._sil`.

Needs ``arm-none-eabi-gcc`` (with newlib) and ``qemu-system-arm`` (Debian:
``apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm``; ``make
arm-toolchain``); without them :class:`~fl_design.errors.CompilerNotFoundError` says which is
missing.

Examples
--------
>>> from fl_design.codegen._pil import ARM_CFLAGS
>>> "-mfpu=fpv4-sp-d16" in ARM_CFLAGS
True
"""

from __future__ import annotations

import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import CompilationError, CompilerNotFoundError, ParameterError
from ._build import run_command
from ._compare import InputComparison, recorded_run, reference_inputs

#: target flags of the Cortex-M4F build (true single-precision FPU, hard-float ABI)
ARM_CFLAGS = ("-O2", "-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16")
#: the QEMU machine (code at 0, RAM at 0x20000000) and its counting mode
QEMU_ARGS = ("-M", "mps2-an386", "-cpu", "cortex-m4", "-nographic", "-monitor", "none",
             "-serial", "none", "-semihosting-config", "enable=on,target=native",
             "-icount", "shift=0")


def pil_tools() -> tuple[str, str, str]:
    """``(arm-none-eabi-gcc, qemu-system-arm, reason)``: paths, or "" and why not.

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> from fl_design.codegen._pil import pil_tools
    >>> len(pil_tools())
    3
    """
    cc, qemu = shutil.which("arm-none-eabi-gcc") or "", shutil.which("qemu-system-arm") or ""
    missing = [name for name, path in (("arm-none-eabi-gcc", cc), ("qemu-system-arm", qemu))
               if not path]
    reason = (f"{' and '.join(missing)} not installed (apt-get install gcc-arm-none-eabi "
              "libnewlib-arm-none-eabi qemu-system-arm, or make arm-toolchain)" if missing
              else "")
    return cc, qemu, reason


@dataclass(frozen=True)
class PilResult(InputComparison):
    """The step on the Cortex-M4F model against ``Design.step`` on the same measurements.

    Parameters
    ----------
    precision, ym, u_c, u_ref, bound
        As in :class:`~fl_design.codegen._compare.InputComparison`: the package's precision,
        the ``(N,)`` measurements fed, the inputs computed on the model and by
        ``Design.step``, the relative bound (fraction of ``max |u_ref|``).
    instructions : float
        Mean instructions per call of ``<prefix>_step``: SysTick ticks of the loop of calls
        over the samples, less those of the same loop calling an empty function of the
        step's signature, times the instructions per tick of a calibration loop, per sample.

    Attributes
    ----------
    max_rel_error : float
        ``max |u_c - u_ref| / max |u_ref|`` (and the other errors of ``InputComparison``).
    passed : bool
        Within the bound, over the run and its last tenth (``matches``).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.codegen._pil import PilResult
    >>> r = PilResult("float", np.zeros(2), np.ones(2), np.ones(2), 1e-4, 85.0)
    >>> r.passed, r.to_dict()["instructions_per_step"]
    (True, 85.0)
    """

    instructions: float

    @property
    def passed(self) -> bool:
        """Within the precision's bound."""
        return self.matches

    def to_dict(self) -> dict:
        """Strict-JSON summary.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.codegen._pil import PilResult
        >>> d = PilResult("float", np.zeros(1), np.ones(1), np.ones(1), 1e-4, 1.0).to_dict()
        >>> d["instructions_per_step"], d["passed"]
        (1.0, True)
        """
        return {**self.errors(), "instructions_per_step": float(self.instructions),
                "passed": self.passed}


def _data_header(pkg, ym, r, y0, u0) -> str:
    real = pkg.precision
    lit = (lambda v: f"{float(v)!r}f") if real == "float" else (lambda v: f"{float(v)!r}")
    rows = lambda a: ",\n".join(", ".join(lit(v) for v in a[i:i + 6])
                                for i in range(0, len(a), 6))
    return (f"/* recorded samples of the PIL run (fl_design) */\n#define PIL_N {len(ym)}u\n"
            f"static const {real} pil_y0 = {lit(y0)};\nstatic const {real} pil_u0 = {lit(u0)};\n"
            f"static const {real} pil_y[{len(ym)}] = {{\n{rows(ym)}}};\n"
            f"static const {real} pil_r[{len(r)}] = {{\n{rows(r)}}};\n")


def _build_pil(cc: str, pkg, ym, r, y0: float, u0: float, cflags, step) -> Path:
    """The PIL image of ``pkg`` (see :func:`run_on_model`), cross-compiled with ``cc``."""
    folder = pkg.out_dir / "build" / "pil"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "pil_data.h").write_text(_data_header(pkg, ym, r, y0, u0))
    pil = pkg.out_dir / "pil"
    strict = [*ARM_CFLAGS, *pkg.flags()[1:], *cflags]
    glue = [*ARM_CFLAGS, "-std=gnu99", "-Wall", "-Wextra", "-Werror", f"-I{pkg.out_dir}",
            f"-I{pil}", f"-I{folder}"]
    units = [(p, strict) for p in pkg.sources]
    if step is not None:  # the main calls step[1]; its file is built like the package
        units.append((Path(step[0]), strict))
        glue.append(f"-D{pkg.prefix}_step={step[1]}")
    objs = []
    for src, flags in units + [(pil / "pil_main.c", glue), (pil / "pil_startup.c", glue)]:
        obj = folder / (Path(src).stem + ".o")
        run_command([cc, *flags, "-c", str(src), "-o", str(obj)],
                    what=f"cross-compiling {Path(src).name}")
        objs.append(str(obj))
    elf = folder / f"{pkg.prefix}_pil.elf"
    run_command([cc, *ARM_CFLAGS, "-nostartfiles", "--specs=nosys.specs",
                 f"-T{pil / 'pil.ld'}", "-o", str(elf), *objs], what="linking the PIL image")
    return elf


def run_on_model(pkg, ym, r, y0: float, u0: float, *, cflags=(), step=None,
                 timeout: float = 300) -> tuple[np.ndarray, float]:
    """Feed ``ym, r`` to ``pkg``'s step on the Cortex-M4F model from ``start(y0, u0)``.

    The image (``<out_dir>/build/pil``): the samples in ``pil_data.h``, the package's sources
    with the strict flags and ``cflags``, the shipped ``pil/`` main, start-up file and linker
    script.

    Parameters
    ----------
    pkg : CPackage
        The package.
    ym, r : numpy.ndarray
        ``(N,)`` measurements and references.
    y0, u0 : float
        Start.
    cflags : sequence of str, optional
        Extra flags of the package's sources.
    step : tuple of (path, str), optional
        A C file and the name of a function in it that replaces ``<prefix>_step`` (same
        signature and state layout: e.g. a hand-written step, for comparison); it is built
        with the package's flags.
    timeout : float, optional
        Seconds for QEMU.

    Returns
    -------
    u : numpy.ndarray
        ``(N,)`` inputs computed on the model (float64 copies).
    instructions : float
        Mean instructions per call (see :class:`PilResult`).

    Raises
    ------
    CompilerNotFoundError
        ``arm-none-eabi-gcc`` or ``qemu-system-arm`` missing.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c
    >>> from fl_design.codegen._pil import pil_tools, run_on_model
    >>> pkg = generate_c(presets.paper_design(), "pil_doc3", precision="float")
    >>> skip = pil_tools()[2] != ""
    >>> skip or float(run_on_model(pkg, np.zeros(4), np.zeros(4), 0.0, 0.5)[0][-1]) == 0.5
    True
    """
    cc, qemu, reason = pil_tools()
    if reason:
        raise CompilerNotFoundError(f"processor-in-the-loop: {reason}")
    elf = _build_pil(cc, pkg, ym, r, y0, u0, tuple(cflags), step)
    out = _run_qemu(qemu, elf, timeout).split()  # semihosting writes to QEMU's stderr
    step_ticks, empty_ticks, count, cal_ticks, cal_instructions = map(int, out[-5:])
    per_tick = cal_instructions / max(cal_ticks, 1)
    instructions = (step_ticks - empty_ticks) / max(count, 1) * per_tick
    words = out[:-6]
    if pkg.precision == "float":
        u_c = np.array([int(w, 16) for w in words], dtype=np.uint32).view(np.float32)
    else:
        u_c = np.array([int(w, 16) for w in words], dtype=np.uint64).view(np.float64)
    return u_c.astype(float), float(instructions)


def processor_in_the_loop(pkg, plant, scenario, *, max_samples: int = 2000,
                          timeout: float = 300, cflags=()) -> PilResult:
    """Run ``pkg``'s step on the Cortex-M4F model fed a recorded closed-loop measurement.

    Parameters
    ----------
    pkg : CPackage
        The package (float: the FPU's single precision; double: software double).
    plant : Plant
        The plant of the recording (:func:`fl_design.simulate`).
    scenario : Scenario
        Its scenario.
    max_samples : int, optional
        Samples fed (the first ones of the run; default 2000).
    timeout : float, optional
        Seconds for QEMU.
    cflags : sequence of str, optional
        Extra flags of the package's sources (e.g. ``("-DFL_NO_FLUSH",)``).

    Returns
    -------
    PilResult

    Raises
    ------
    CompilerNotFoundError
        The cross-compiler or QEMU is missing.
    ParameterError
        ``max_samples`` < 1.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design import presets
    >>> from fl_design.codegen._pil import pil_tools, processor_in_the_loop
    >>> pkg = fl.generate_c(presets.paper_design(), "pil_doc2", precision="float")
    >>> res = None if pil_tools()[2] else processor_in_the_loop(
    ...     pkg, fl.plants.trms_yaw(), fl.Scenario(0.3, 0.2))
    >>> res is None or res.passed
    True
    """
    from ._compare import bound_for

    if not isinstance(max_samples, int) or max_samples < 1:
        raise ParameterError(f"max_samples={max_samples!r} must be an integer >= 1")
    if pkg.precision == "q31":
        raise ParameterError("processor_in_the_loop runs a double or float package on the "
                             "Cortex-M4F; a precision='q31' package runs on the Cortex-M3 and "
                             "M0+ models with fl_design.codegen._pil_q31.q31_on_model (or the "
                             "package's make check-m3 / check-m0plus)")
    _, _, reason = pil_tools()
    if reason:
        raise CompilerNotFoundError(f"processor-in-the-loop: {reason}")
    ym, r, u0 = recorded_run(plant, pkg.design, scenario, max_samples=max_samples)
    u_c, instructions = run_on_model(pkg, ym, r, float(ym[0]), u0, cflags=cflags,
                                     timeout=timeout)
    u_ref = reference_inputs(pkg.step_design, ym, r, u0)
    return PilResult(pkg.precision, ym, u_c, u_ref, bound_for(pkg.precision), instructions)


def _run_qemu(qemu: str, elf: Path, timeout: float, *, args=QEMU_ARGS) -> str:
    try:
        proc = subprocess.run([qemu, *args, "-kernel", str(elf)], capture_output=True,
                              text=True, stdin=subprocess.DEVNULL, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        raise CompilationError(f"QEMU (PIL run) timed out after {timeout:g} s") from None
    if proc.returncode != 0 or "ticks" not in proc.stderr:
        raise CompilationError(f"the PIL run on QEMU failed (exit {proc.returncode}): "
                               f"{proc.stderr[-1500:]}")
    return proc.stderr


__all__ = ["ARM_CFLAGS", "QEMU_ARGS", "PilResult", "pil_tools",
           "processor_in_the_loop", "run_on_model"]
