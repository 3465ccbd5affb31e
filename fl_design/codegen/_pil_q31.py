"""The Q31 step on the FPU-less Cortex-M models: its inputs and instructions per call.

:func:`q31_on_model` cross-compiles a ``precision="q31"`` package's step with a bare-metal
harness (``templates/pil_main_q31.c.in``: start-up, the recorded samples, SysTick-timed blocks
of calls against the same loop calling an empty function, a calibration loop) for
``-mcpu=cortex-m3`` or ``-mcpu=cortex-m0plus`` and runs it under ``qemu-system-arm -icount
shift=0`` (one instruction per tick of the virtual clock): the Cortex-M3 on ``mps2-an385``,
the Cortex-M0+ build on ``microbit`` (QEMU's Cortex-M0: the same ARMv6-M instruction set; QEMU
counts instructions, not cycles, so the M0+'s shorter pipeline does not enter the count).

Examples
--------
>>> from fl_design.codegen._pil_q31 import Q31_TARGETS
>>> Q31_TARGETS["cortex-m3"][0]
'mps2-an385'
"""

from __future__ import annotations

import re
from importlib import resources

import numpy as np

from ..errors import CompilerNotFoundError, ParameterError
from ._build import run_command
from ._pil import QEMU_ARGS, _run_qemu, pil_tools
from ._template import render

#: cpu -> (QEMU machine, QEMU cpu, flash, RAM)
Q31_TARGETS = {"cortex-m3": ("mps2-an385", "cortex-m3", "4M", "4M"),
               "cortex-m0plus": ("microbit", "cortex-m0", "256K", "16K")}


def _q(header: str, name: str) -> int:
    m = re.search(rf"#define {name}\s+\(?\(?(?:INT32_C\()?(-?\d+)", header)
    if m is None:
        raise ParameterError(f"the package's header has no {name}: not a q31 package")
    return int(m.group(1))


def _data(yq, rq) -> str:
    rows = lambda a: ",\n".join(", ".join(f"INT32_C({int(v)})" for v in a[i:i + 8])
                                for i in range(0, len(a), 8))
    return (f"/* recorded samples of the Q31 PIL run (fl_design) */\n#define PIL_N {len(yq)}u\n"
            f"static const int32_t pil_y[{len(yq)}] = {{\n{rows(yq)}}};\n"
            f"static const int32_t pil_r[{len(rq)}] = {{\n{rows(rq)}}};\n")


def q31_on_model(pkg, y, r, *, cpu: str, timeout: float = 300) -> tuple[np.ndarray, float]:
    """Feed ``y, r`` (real) to a q31 package's step on the ``cpu`` model from ``start(y[0],
    U_OP)``.

    Parameters
    ----------
    pkg : CPackage
        A ``precision="q31"`` package.
    y, r : numpy.ndarray
        ``(N,)`` measurements and references (real; quantized as ``main.c`` does).
    cpu : {"cortex-m3", "cortex-m0plus"}
        The target (:data:`Q31_TARGETS`).
    timeout : float, optional
        Seconds for QEMU.

    Returns
    -------
    u : numpy.ndarray
        ``(N,)`` inputs (real: ``u / 2^U_FRAC_BITS``).
    instructions : float
        Mean instructions per call beyond an empty call.

    Raises
    ------
    CompilerNotFoundError
        ``arm-none-eabi-gcc`` or ``qemu-system-arm`` missing.
    ParameterError
        Not a q31 package, or an unknown ``cpu``.

    Examples
    --------
    >>> import numpy as np
    >>> import fl_design as fl
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c
    >>> from fl_design.codegen._pil import pil_tools
    >>> from fl_design.codegen._pil_q31 import q31_on_model
    >>> pkg = generate_c(presets.paper_design(), "q31_doc", precision="q31",
    ...                  plant=fl.plants.trms_yaw())
    >>> y = np.full(8, 0.1)
    >>> pil_tools()[2] != "" or q31_on_model(pkg, y, y, cpu="cortex-m3")[0].shape == (8,)
    True
    """
    if cpu not in Q31_TARGETS:
        raise ParameterError(f"cpu={cpu!r}: one of {sorted(Q31_TARGETS)}")
    if pkg.precision != "q31":
        raise ParameterError(f"a {pkg.precision!r} package: q31_on_model runs precision='q31'")
    cc, qemu, reason = pil_tools()
    if reason:
        raise CompilerNotFoundError(f"the Q31 PIL run: {reason}")
    machine, qemu_cpu, flash, ram = Q31_TARGETS[cpu]
    header = pkg.header.read_text()
    f_y, f_u = _q(header, f"{pkg.prefix.upper()}_Y_FRAC_BITS"), _q(
        header, f"{pkg.prefix.upper()}_U_FRAC_BITS")
    quant = lambda v: np.clip(np.round(np.ldexp(np.asarray(v, dtype=float), f_y)),
                              -2.0**31, 2.0**31 - 1).astype(np.int64)
    folder = pkg.out_dir / "build" / f"pil_q31_{cpu}"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "pil_data.h").write_text(_data(quant(y), quant(r)))
    text = lambda name: resources.files("fl_design.codegen").joinpath("templates", name).read_text()
    subs = {"PREFIX": pkg.prefix, "P": pkg.prefix.upper(), "VERSION": _version(),
            "MACHINE": machine, "FLASH": flash, "RAM": ram}
    (folder / "pil_main_q31.c").write_text(render(text("pil_main_q31.c.in"), subs))
    (folder / "pil_q31.ld").write_text(render(text("pil_q31.ld.in"), subs))
    arch = [f"-mcpu={cpu}", "-mthumb", "-O2"]
    objs = []
    for src, flags in ((pkg.sources[0], [*arch, *pkg.flags()[1:]]),
                       (folder / "pil_main_q31.c", [*arch, "-std=gnu99", "-Wall", "-Wextra",
                                                    "-Werror", f"-I{pkg.out_dir}", f"-I{folder}"])):
        obj = folder / (src.stem + ".o")
        run_command([cc, *flags, "-c", str(src), "-o", str(obj)],
                    what=f"cross-compiling {src.name} for {cpu}")
        objs.append(str(obj))
    elf = folder / f"{pkg.prefix}_q31_{cpu}.elf"
    run_command([cc, *arch, "-nostartfiles", "--specs=nosys.specs", f"-T{folder / 'pil_q31.ld'}",
                 "-o", str(elf), *objs], what=f"linking the Q31 PIL image for {cpu}")
    args = list(QEMU_ARGS)
    args[args.index("-M") + 1], args[args.index("-cpu") + 1] = machine, qemu_cpu
    words = _run_qemu(qemu, elf, timeout, args=tuple(args)).split()
    step_ticks, empty_ticks, count, cal_ticks, cal_instructions = map(int, words[-5:])
    u = np.array([int(w, 16) for w in words[:-6]], dtype=np.uint32).view(np.int32)
    per_tick = cal_instructions / max(cal_ticks, 1)
    return np.ldexp(u.astype(float), -f_u), (step_ticks - empty_ticks) / max(count, 1) * per_tick


def q31_pil(pkg, plant, scenario, *, max_samples: int = 1000) -> dict:
    """The Q31 step on every model of :data:`Q31_TARGETS`, fed the recorded run of
    :func:`fl_design.simulate` on ``plant`` and ``scenario``, against the host build.

    Parameters
    ----------
    pkg : CPackage
        A ``precision="q31"`` package.
    plant, scenario
        The run whose measurements are fed (as :meth:`CPackage.pil`).
    max_samples : int, optional
        Samples fed (default 1000).

    Returns
    -------
    dict
        ``cpu -> (instructions per call, max |u_model - u_host|)`` (0 when bit-exact).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c
    >>> from fl_design.codegen._pil import pil_tools
    >>> from fl_design.codegen._pil_q31 import q31_pil
    >>> pkg = generate_c(presets.paper_design(), "q31_pil_doc", precision="q31",
    ...                  plant=fl.plants.trms_yaw())
    >>> res = None if pil_tools()[2] else q31_pil(pkg, fl.plants.trms_yaw(),
    ...                                           fl.Scenario(0.3, 0.05), max_samples=50)
    >>> res is None or all(diff == 0.0 for _, diff in res.values())
    True
    """
    from ._compare import recorded_run

    ym, r, _ = recorded_run(plant, pkg.design, scenario, max_samples=max_samples)
    host = pkg.run(ym, r, start=True)
    out = {}
    for cpu in Q31_TARGETS:
        u, n = q31_on_model(pkg, ym, r, cpu=cpu)
        out[cpu] = (n, float(np.max(np.abs(u - host))))
    return out


def _version() -> str:
    import fl_design

    return fl_design.__version__


__all__ = ["Q31_TARGETS", "q31_on_model", "q31_pil"]
