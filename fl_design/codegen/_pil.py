"""Processor-in-the-loop: the package's step on a Cortex-M4F model (QEMU ``mps2-an386``).

:func:`processor_in_the_loop` records the measurements of :func:`fl_design.simulate` on the
user's plant and scenario, writes them into ``pil_data.h``, cross-compiles the package with the
shipped start-up file and linker script (``pil/`` in the package) for ``-mcpu=cortex-m4
-mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16`` (the package sources with the strict flags), runs it
under ``qemu-system-arm -M mps2-an386 -icount shift=0`` (one instruction per virtual clock
tick: SysTick counts instructions; QEMU is not cycle-accurate, so the cost is reported in
instructions per step, not time), and compares the inputs ``u`` it prints (bit patterns, via
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
from ._package import run_command

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
class PilResult:
    """The step on the Cortex-M4F model against ``Design.step`` on the same measurements.

    Parameters
    ----------
    precision : str
        Of the package.
    u_c : numpy.ndarray
        ``(N,)`` inputs computed on the model.
    u_ref : numpy.ndarray
        ``(N,)`` inputs of ``Design.step``.
    bound : float
        Relative bound (fraction of ``max |u_ref|``).
    instructions : float
        Mean instructions per call of ``<prefix>_step`` (SysTick ticks over the run, the
        empty measurement's subtracted, times the instructions per tick of a calibration loop).

    Attributes
    ----------
    max_rel_error : float
        ``max |u_c - u_ref| / max |u_ref|``.
    passed : bool
        ``max_rel_error <= bound``.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.codegen._pil import PilResult
    >>> r = PilResult("float", np.ones(2), np.ones(2), 1e-4, 85.0)
    >>> r.passed, r.to_dict()["instructions_per_step"]
    (True, 85.0)
    """

    precision: str
    u_c: np.ndarray
    u_ref: np.ndarray
    bound: float
    instructions: float

    @property
    def max_rel_error(self) -> float:
        """``max |u_c - u_ref| / max |u_ref|``."""
        scale = max(float(np.max(np.abs(self.u_ref))), np.finfo(float).tiny)
        return float(np.max(np.abs(self.u_c - self.u_ref))) / scale

    @property
    def passed(self) -> bool:
        """Within the precision's bound."""
        return bool(self.max_rel_error <= self.bound)

    def to_dict(self) -> dict:
        """Strict-JSON summary.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.codegen._pil import PilResult
        >>> sorted(PilResult("float", np.ones(1), np.ones(1), 1e-4, 1.0).to_dict())[:2]
        ['bound', 'instructions_per_step']
        """
        return {"precision": self.precision, "n_samples": int(self.u_c.size),
                "max_rel_error": self.max_rel_error, "bound": float(self.bound),
                "instructions_per_step": float(self.instructions), "passed": self.passed}


def _data_header(pkg, ym, r, y0, u0) -> str:
    real = pkg.precision
    lit = (lambda v: f"{float(v)!r}f") if real == "float" else (lambda v: f"{float(v)!r}")
    rows = lambda a: ",\n".join(", ".join(lit(v) for v in a[i:i + 6])
                                for i in range(0, len(a), 6))
    return (f"/* recorded samples of the PIL run (fl_design) */\n#define PIL_N {len(ym)}u\n"
            f"static const {real} pil_y0 = {lit(y0)};\nstatic const {real} pil_u0 = {lit(u0)};\n"
            f"static const {real} pil_y[{len(ym)}] = {{\n{rows(ym)}}};\n"
            f"static const {real} pil_r[{len(r)}] = {{\n{rows(r)}}};\n")


def build_pil(pkg, ym, r, y0: float, u0: float, *, cflags=()) -> Path:
    """Cross-compile the PIL image of ``pkg`` fed ``ym, r`` from ``start(y0, u0)``; its path.

    Parameters
    ----------
    pkg : CPackage
        The package.
    ym, r : numpy.ndarray
        ``(N,)`` measurements and references.
    y0, u0 : float
        Start.
    cflags : sequence of str, optional
        Extra flags of the package's sources (e.g. ``("-DFL_NO_FLUSH",)``).

    Returns
    -------
    pathlib.Path
        The ELF image.

    Raises
    ------
    CompilerNotFoundError
        ``arm-none-eabi-gcc`` or ``qemu-system-arm`` missing.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c
    >>> from fl_design.codegen._pil import build_pil, pil_tools
    >>> pkg = generate_c(presets.paper_design(), "pil_doc", precision="float")
    >>> pil_tools()[2] != "" or build_pil(pkg, np.zeros(3), np.zeros(3), 0.0, 0.0).suffix == ".elf"
    True
    """
    cc, _, reason = pil_tools()
    if reason:
        raise CompilerNotFoundError(f"processor-in-the-loop: {reason}")
    folder = pkg.out_dir / "build" / "pil"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "pil_data.h").write_text(_data_header(pkg, ym, r, y0, u0))
    pil = pkg.out_dir / "pil"
    strict = [*ARM_CFLAGS, *pkg.flags()[1:], *cflags]
    glue = [*ARM_CFLAGS, "-std=gnu99", "-Wall", "-Wextra", "-Werror", f"-I{pkg.out_dir}",
            f"-I{pil}", f"-I{folder}"]
    objs = []
    for src, flags in [(p, strict) for p in pkg.sources] + [
            (pil / "pil_main.c", glue), (pil / "pil_startup.c", glue)]:
        obj = folder / (Path(src).stem + ".o")
        run_command([cc, *flags, "-c", str(src), "-o", str(obj)],
                    what=f"cross-compiling {Path(src).name}")
        objs.append(str(obj))
    elf = folder / f"{pkg.prefix}_pil.elf"
    run_command([cc, *ARM_CFLAGS, "-nostartfiles", "--specs=nosys.specs",
                 f"-T{pil / 'pil.ld'}", "-o", str(elf), *objs], what="linking the PIL image")
    return elf


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
    from ..sim import simulate
    from ..sim._run import prepare_run
    from ._sil import bound_for, reference_run

    if not isinstance(max_samples, int) or max_samples < 1:
        raise ParameterError(f"max_samples={max_samples!r} must be an integer >= 1")
    _, qemu, reason = pil_tools()
    if reason:
        raise CompilerNotFoundError(f"processor-in-the-loop: {reason}")
    run = prepare_run(plant, pkg.design, scenario)
    resp = simulate(plant, pkg.design, run.scenario)
    n = min(max_samples, int(np.flatnonzero(np.isfinite(resp.ym))[-1]) + 1)
    ym, r = resp.ym[:n], resp.r[:n]
    elf = build_pil(pkg, ym, r, float(ym[0]), run.u0, cflags=tuple(cflags))
    out = _run_qemu(qemu, elf, timeout).split()  # semihosting writes to QEMU's stderr
    step_ticks, empty_ticks, count, cal_ticks, cal_instructions = map(int, out[-5:])
    per_tick = cal_instructions / max(cal_ticks, 1)
    instructions = (step_ticks - empty_ticks) / max(count, 1) * per_tick
    words = out[:-6]
    if pkg.precision == "float":
        u_c = np.array([int(w, 16) for w in words], dtype=np.uint32).view(np.float32)
    else:
        u_c = np.array([int(w, 16) for w in words], dtype=np.uint64).view(np.float64)
    used = pkg.step_design
    u_ref, _, _ = reference_run(used, ym, r, state0=used.initial_state(y0=float(ym[0]),
                                                                      u0=run.u0))
    return PilResult(pkg.precision, u_c.astype(float), u_ref, bound_for(pkg.precision),
                     float(instructions))


def _run_qemu(qemu: str, elf: Path, timeout: float) -> str:
    try:
        proc = subprocess.run([qemu, *QEMU_ARGS, "-kernel", str(elf)], capture_output=True,
                              text=True, stdin=subprocess.DEVNULL, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        raise CompilationError(f"QEMU (PIL run) timed out after {timeout:g} s") from None
    if proc.returncode != 0 or "ticks" not in proc.stderr:
        raise CompilationError(f"the PIL run on QEMU failed (exit {proc.returncode}): "
                               f"{proc.stderr[-1500:]}")
    return proc.stderr


__all__ = ["ARM_CFLAGS", "QEMU_ARGS", "PilResult", "build_pil", "pil_tools",
           "processor_in_the_loop"]
