"""The computational cost of a generated step, and the paper's EHGO vs least-squares table.

Per package (:meth:`CPackage.cost`): the operations of one step by kind, read from the
instruction list of the generated CasADi function (the code that runs, after CasADi's
simplifications); the stack frame (``-fstack-usage``: the step and the static functions it
calls that were not inlined, along the deepest chain: an upper bound, libm excluded); the code
and data size of the package's object (``size``); the measured time per step of the compiled
harness (``--bench``, ``-O2``: ``main.c`` linked with that same object, :func:`bench_executable`);
and, for a single-precision package when ``arm-none-eabi-gcc`` is installed, the same for a
Cortex-M4F with the double-precision helpers (``__aeabi_d*``) it calls (must be none).

:func:`compare_costs` with ``cache=True`` (the main job) reuses a row measured earlier when
everything it depends on is the same (:func:`cost_key`): the generated files, the compilers,
the flags, the timing run's length, fl_design's code generator and this machine. The row is
JSON in the private cache folder (:mod:`fl_design._cache`: owned by the user, mode 0700,
each file checked against its size and SHA-256), so a file another user wrote is never read.

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen import operation_counts, core_function
>>> ops = operation_counts(core_function(presets.paper_design(), "fl"))
>>> ops["mul"] > 0 and "const" not in ops
True
"""

from __future__ import annotations

import hashlib
import json
import math
import platform
import shutil
from dataclasses import dataclass, field
from pathlib import Path

from ._build import compiler_or_raise, run_command
from ._opcount import FLOP_KINDS, operation_counts
from ._step import core_function

ARM_FLAGS = ("-O2", "-std=c99", "-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16",
             "-mfloat-abi=hard", "-fstack-usage")


def _stack_usage(files) -> dict[str, int]:
    out = {}
    for su in files:
        for line in Path(su).read_text().splitlines():
            loc, size, _ = line.split("\t")
            out[loc.rsplit(":", 1)[-1]] = int(size)
    return out


def _size(objects, size_tool: str) -> tuple[int, int]:
    text = run_command([size_tool, *map(str, objects)], what="size").splitlines()[1:]
    cols = [list(map(int, line.split()[:3])) for line in text]
    return sum(c[0] for c in cols), sum(c[1] + c[2] for c in cols)


def _objects(pkg, cc: str, flags, folder: Path) -> tuple[list[Path], dict[str, int]]:
    folder.mkdir(parents=True, exist_ok=True)
    objs = []
    for src in pkg.sources:
        obj = folder / (src.stem + ".o")
        run_command([cc, *flags, "-fstack-usage", "-c", str(src), "-o", str(obj)],
                    what=f"compiling {src.name} with {cc}")
        objs.append(obj)
    frames = _stack_usage(folder.glob("*.su"))
    p = pkg.prefix
    # the step and the static functions it may call (those not inlined): the deepest chain,
    # step -> checked -> run -> core (or start, reject); an upper bound (tail calls share)
    f = lambda name: frames.get(f"{p}_{name}", 0)
    run = f("run") + f("core")
    chain = f("step") + max(run, f("checked") + max(run, f("start"), f("reject")))
    return objs, {"stack": chain}


def bench_executable(pkg, objects, *, compiler=None) -> Path:
    """The harness ``main.c`` linked with the package's objects already compiled (no second
    compile of the package: the byte-for-byte executable of :meth:`CPackage.build`).

    ``objects`` are those :func:`step_cost` measured (compiled with the same :meth:`CPackage.flags`;
    ``-fstack-usage`` only writes the ``.su`` files, the object is the same): the timed code is
    the measured code, and the package's compile, about 0.2-0.3 s per design, is paid once.

    Parameters
    ----------
    pkg : CPackage
        The package.
    objects : sequence of path-like
        The objects of ``pkg.sources``, compiled with ``pkg.flags()``.
    compiler : str, optional
        C compiler (the one that compiled ``objects``).

    Returns
    -------
    pathlib.Path
        The executable, where :meth:`CPackage.build` puts it.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c
    >>> from fl_design.codegen._cost import _objects, bench_executable
    >>> from fl_design.codegen._package import compiler_or_raise
    >>> pkg, cc = generate_c(presets.paper_design(), "bench_doc"), compiler_or_raise()
    >>> objs, _ = _objects(pkg, cc, pkg.flags(), pkg.out_dir / "build" / "host")
    >>> bench_executable(pkg, objs, compiler=cc).name.startswith("fl_main")
    True
    """
    cc = compiler_or_raise(compiler)
    exe = pkg.out_dir / "build" / f"{pkg.prefix}_main_{Path(cc).name}"
    exe.parent.mkdir(exist_ok=True)
    run_command([cc, *pkg.flags(), "-o", str(exe), str(pkg.out_dir / "main.c"),
                 *map(str, objects), "-lm"],
                what=f"linking the {pkg.precision} harness with {cc}")
    return exe


def _arm(pkg) -> tuple[dict | None, str]:
    arm_cc = shutil.which("arm-none-eabi-gcc")
    if arm_cc is None:
        return None, "arm-none-eabi-gcc is not installed (make arm-toolchain installs it)"
    flags = [*ARM_FLAGS, *pkg.flags(optimize="-O2")[1:]]
    objs, frames = _objects(pkg, arm_cc, flags, pkg.out_dir / "build" / "cortex-m4")
    undefined = set()
    for obj in objs:
        undefined |= set(run_command(["arm-none-eabi-nm", "-u", str(obj)], what="nm").split())
    undefined -= {"U"}
    code, data = _size(objs, "arm-none-eabi-size")
    helpers = sorted(u for u in undefined if u.startswith("__aeabi_d"))
    return {"code_bytes": code, "data_bytes": data, "stack_bytes": frames["stack"],
            "undefined": sorted(undefined), "double_helpers": helpers}, ""


@dataclass(frozen=True)
class StepCost:
    """What one call of a generated step costs (see the module docstring).

    Parameters
    ----------
    name : str
        Row name (e.g. ``"EHGO"``, ``"LS(26)"``).
    precision : str
        ``"double"`` or ``"float"``.
    operations : dict
        ``{kind: count}`` from the instruction list.
    stack_bytes : int
        Stack of ``<prefix>_step`` and CasADi's function (host compiler, ``-O2``).
    code_bytes, data_bytes : int
        ``text`` and ``data + bss`` of the two objects.
    ns_per_step : float
        Measured time per call (host, ``-O2``).
    state_bytes : int
        Size of the numbers of the state struct.
    arm : dict or None
        Cortex-M4F figures (``code_bytes``, ``data_bytes``, ``stack_bytes``, ``undefined``,
        ``double_helpers``), None when not built.
    arm_skipped : str
        Why ``arm`` is None ("" otherwise).

    Examples
    --------
    >>> from fl_design.codegen import StepCost
    >>> c = StepCost("EHGO", "double", {"add": 3, "mul": 2}, 64, 900, 40, 10.0, 40)
    >>> c.flops, c.to_dict()["ns_per_step"]
    (5, 10.0)
    """

    name: str
    precision: str
    operations: dict
    stack_bytes: int
    code_bytes: int
    data_bytes: int
    ns_per_step: float
    state_bytes: int
    arm: dict | None = None
    arm_skipped: str = field(default="")

    @property
    def flops(self) -> int:
        """Floating-point operations per step (every kind of :data:`FLOP_KINDS`)."""
        return int(sum(self.operations.values()))

    def to_dict(self) -> dict:
        """Strict-JSON fields (``flops`` included).

        Examples
        --------
        >>> from fl_design.codegen import StepCost
        >>> StepCost("x", "float", {}, 0, 0, 0, 1.0, 4).to_dict()["flops"]
        0
        """
        ns = self.ns_per_step if math.isfinite(self.ns_per_step) else None
        return {"name": self.name, "precision": self.precision, "flops": self.flops,
                "operations": dict(self.operations), "stack_bytes": self.stack_bytes,
                "code_bytes": self.code_bytes, "data_bytes": self.data_bytes,
                "ns_per_step": ns, "state_bytes": self.state_bytes, "arm": self.arm,
                "arm_skipped": self.arm_skipped}


def step_cost(pkg, *, name=None, bench_steps: int = 2_000_000, compiler=None) -> StepCost:
    """The :class:`StepCost` of a package (what :meth:`CPackage.cost` returns).

    Parameters
    ----------
    pkg : CPackage
        The package.
    name : str, optional
        Row name; default ``"EHGO"`` or ``"LS(N)"``.
    bench_steps : int, optional
        Steps of the timing run (the best of three runs is kept).
    compiler : str, optional
        C compiler.

    Returns
    -------
    StepCost

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c, step_cost
    >>> step_cost(generate_c(presets.least_squares_design(9), "sc"), bench_steps=10).name
    'LS(9)'
    """
    from .. import design as dsg

    cc = compiler_or_raise(compiler)
    est = pkg.step_design.estimator
    if name is None:
        name = f"LS({est.window})" if isinstance(est, dsg.LeastSquaresEstimator) else "EHGO"
    ops = operation_counts(core_function(pkg.step_design, pkg.prefix))
    objs, frames = _objects(pkg, cc, pkg.flags(), pkg.out_dir / "build" / "host")
    code, data = _size(objs, "size")
    exe = bench_executable(pkg, objs, compiler=cc)
    times = [float(run_command([str(exe), "--bench", str(int(bench_steps))], what="bench")
                   .split()[0]) for _ in range(3)]
    arm, skipped = (_arm(pkg) if pkg.precision == "float"
                    else (None, f"{pkg.precision} build (the Cortex-M4F figures are of float)"))
    width = 4 if pkg.precision in ("float", "q31") else 8
    return StepCost(name, pkg.precision, ops, frames["stack"], code, data, min(times),
                    width * pkg.step_design.state_size, arm, skipped)


@dataclass(frozen=True)
class CostTable:
    """The paper's computational-cost comparison: one :class:`StepCost` per design.

    Parameters
    ----------
    rows : tuple of StepCost
        The rows, in order.
    cached : int, optional
        How many rows were read from the cache (measured by an earlier run on this machine,
        :func:`compare_costs` ``cache=True``) rather than measured now.

    Examples
    --------
    >>> from fl_design.codegen import CostTable, StepCost
    >>> t = CostTable((StepCost("EHGO", "double", {"add": 1}, 8, 9, 0, 2.0, 40),))
    >>> print(t.to_markdown().splitlines()[2])
    | EHGO | double | 1 | 0 | 1 | 0 | 0 | 2 | 8 | 9 | 40 |
    """

    rows: tuple
    cached: int = 0

    def to_dict(self) -> dict:
        """``{"rows": [StepCost.to_dict(), ...], "cached": n}`` (strict JSON).

        Examples
        --------
        >>> from fl_design.codegen import CostTable
        >>> CostTable(()).to_dict()
        {'rows': [], 'cached': 0}
        """
        return {"rows": [row.to_dict() for row in self.rows], "cached": self.cached}

    def to_markdown(self) -> str:
        """A Markdown table: flops by kind, ns per step, stack, code and state bytes.

        Examples
        --------
        >>> from fl_design.codegen import CostTable
        >>> CostTable(()).to_markdown().splitlines()[0].split(" | ")[1]
        'precision'
        """
        head = ("| design | precision | flops | mul | add | min/max, compare, select | other "
                "| ns/step | stack B | code B | state B |")
        lines = [head, "|" + " --- |" * 11]
        for c in self.rows:
            o = c.operations
            logic = o.get("minmax", 0) + o.get("compare", 0) + o.get("select", 0)
            other = o.get("div", 0) + o.get("neg", 0) + o.get("math", 0)
            lines.append(f"| {c.name} | {c.precision} | {c.flops} | {o.get('mul', 0)} | "
                         f"{o.get('add', 0)} | {logic} | {other} | {c.ns_per_step:.3g} | "
                         f"{c.stack_bytes} | {c.code_bytes} | {c.state_bytes} |")
        return "\n".join(lines)


#: Bumped when the stored row's layout or the measurement changes.
COST_FORMAT = "fl_design step cost 1"


def _machine() -> str:
    """This machine's identity for timings: host, architecture and CPU model
    (:func:`fl_design._isa.cpu_model`)."""
    from .._isa import cpu_model

    return f"{platform.node()}|{platform.machine()}|{cpu_model()}"


def _tool(cc: str | None) -> str:
    """A compiler's resolved path and ``--version`` (empty when absent)."""
    path = shutil.which(cc) if cc else None
    if path is None:
        return ""
    try:
        version = run_command([path, "--version"], what=f"{cc} --version")
    except Exception:  # noqa: BLE001 - an unusable tool: a key that never matches a cache
        version = "unusable"
    return f"{Path(path).resolve()}\n{version}"


def cost_key(pkg, *, name: str, bench_steps: int, compiler: str) -> str:
    """The content key of a package's :class:`StepCost` (:func:`compare_costs` ``cache=True``).

    SHA-256 of :data:`COST_FORMAT`, the row's name, the precision, the timing run's length,
    every file at the package's top level (not ``build/``, ``pil/`` or the output marker),
    the flags, the host compiler and (for ``float``) ``arm-none-eabi-gcc`` (resolved path and
    ``--version``), the source of ``fl_design.codegen`` and this machine (host name,
    architecture, CPU model).

    Parameters
    ----------
    pkg : CPackage
        A generated package.
    name : str
        Row name.
    bench_steps : int
        Steps of each timing run.
    compiler : str
        The host C compiler.

    Returns
    -------
    str
        64 hexadecimal digits.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c
    >>> from fl_design.codegen._cost import cost_key
    >>> from fl_design.codegen._package import compiler_or_raise
    >>> pkg, cc = generate_c(presets.paper_design(), "key"), compiler_or_raise()
    >>> key = cost_key(pkg, name="EHGO", bench_steps=10, compiler=cc)
    >>> len(key), key != cost_key(pkg, name="EHGO", bench_steps=20, compiler=cc)
    (64, True)
    """
    h = hashlib.sha256()

    def part(data) -> None:
        data = data if isinstance(data, bytes) else str(data).encode()
        h.update(len(data).to_bytes(8, "little") + data)

    for item in (COST_FORMAT, name, pkg.precision, int(bench_steps), " ".join(pkg.flags()),
                 _tool(compiler), _tool("arm-none-eabi-gcc") if pkg.precision == "float"
                 else "", _machine()):
        part(item)
    for f in sorted(Path(pkg.out_dir).iterdir()):  # the package's files (not the marker)
        if f.is_file() and not f.is_symlink() and not f.name.startswith("."):
            part(f.name)
            part(f.read_bytes())
    for f in sorted(Path(__file__).parent.glob("*.py")):
        part(f.name)
        part(f.read_bytes())
    return h.hexdigest()


def cached_cost(pkg, *, name: str, bench_steps: int, compiler) -> tuple[StepCost, bool]:
    """``pkg.cost(...)`` through the private cache: (row, whether it came from the cache)."""
    from .._cache import cache_directory, read_verified, write_verified
    from ..errors import ComputationError

    cc = compiler_or_raise(compiler)
    file = f"cost-{cost_key(pkg, name=name, bench_steps=bench_steps, compiler=cc)}.json"
    try:
        data = read_verified(cache_directory() / file)
    except (OSError, ComputationError):  # an unsafe cache folder: measure (it warned)
        data = None
    if data is not None:
        try:
            row = json.loads(data)
            ns = row.pop("ns_per_step")
            row.pop("flops")  # a property of the operations
            return StepCost(**row, ns_per_step=math.nan if ns is None else ns), True
        except (ValueError, TypeError, KeyError, AttributeError):
            pass  # an older or malformed entry: measure again
    cost = pkg.cost(name=name, bench_steps=bench_steps, compiler=cc)
    try:
        write_verified(file, json.dumps(cost.to_dict()).encode())
    except (OSError, ComputationError):
        pass  # no cache: the row is still measured
    return cost, False


__all__ = ["ARM_FLAGS", "COST_FORMAT", "FLOP_KINDS", "CostTable", "StepCost",
           "bench_executable", "cached_cost", "cost_key", "operation_counts", "step_cost"]
