"""``CPackage``: a generated C package, its builds, its software-in-the-loop check and its cost.

Builds go to ``<out_dir>/build`` with the system C compiler (:func:`find_compiler`), always
with the strict flags ``-std=c99 -pedantic -Wall -Wextra -Werror`` (plus
``-Wdouble-promotion -Wfloat-conversion`` in single precision). :meth:`CPackage.verify` runs
the compiled step in closed loop with the simulated plant and compares it with
:attr:`fl_design.Design.step` fed the same measurements (see :mod:`fl_design.codegen._sil`).

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen import generate_c
>>> pkg = generate_c(presets.paper_design(), "pkg_doc")
>>> u = pkg.run([0.0, 0.0, 0.0], [0.3, 0.3, 0.3])    # the compiled harness
>>> bool(u[0] > 0.0)
True
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._toolchain import STRICT_CFLAGS
from ..errors import ParameterError
from ._build import FLOAT_WARNINGS, SANITIZE_FLAGS, compiler_or_raise, run_command


@dataclass(frozen=True)
class CPackage:
    """The files written by :func:`~fl_design.generate_c`, and what can be done with them.

    Parameters
    ----------
    out_dir : pathlib.Path
        The package folder.
    design : Design
        The user's design (the reference of :meth:`verify`).
    step_design : Design
        The design whose step was generated (``design`` itself, or for ``"float"`` the same
        design with its EHGO in the delta realization).
    precision : str
        ``"double"`` or ``"float"``.
    prefix : str
        C prefix.
    files : tuple of pathlib.Path
        Files written.
    predicted_float_error : float or None, optional
        The float build's predicted relative error (``generate_c`` with ``plant`` and
        ``scenario``), else None.
    guard : GuardSettings, optional
        The defaults of the step's checks (:func:`fl_design.codegen._guard.guard_settings`).

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c
    >>> pkg = generate_c(presets.paper_design(), "pkg_cls", prefix="trms")
    >>> pkg.header.name, pkg.precision
    ('trms.h', 'double')
    """

    out_dir: Path
    design: object
    step_design: object
    precision: str
    prefix: str
    files: tuple
    predicted_float_error: float | None = None
    guard: object = None

    @property
    def header(self) -> Path:
        """``<prefix>.h``, the API."""
        return self.out_dir / f"{self.prefix}.h"

    @property
    def sources(self) -> tuple[Path]:
        """``(<prefix>.c,)``: the one source of the package (it includes its header)."""
        return (self.out_dir / f"{self.prefix}.c",)

    def flags(self, *, sanitize: bool = False, optimize: str = "-O2") -> list[str]:
        """Compiler flags of the package's builds (strict; float warnings; sanitizers).

        Parameters
        ----------
        sanitize : bool, optional
            Add ASan + UBSan.
        optimize : str, optional
            Optimization flag.

        Returns
        -------
        list of str

        Examples
        --------
        >>> from fl_design import presets
        >>> from fl_design.codegen import generate_c
        >>> "-Wdouble-promotion" in generate_c(presets.paper_design(), "pf",
        ...                                    precision="float").flags()
        True
        """
        out = [optimize, *STRICT_CFLAGS, *FLOAT_WARNINGS]
        return out + (list(SANITIZE_FLAGS) if sanitize else [])

    def build(self, *, sanitize: bool = False, compiler: str | None = None) -> Path:
        """Compile the SIL harness ``main.c`` with the package; the executable's path.

        Parameters
        ----------
        sanitize : bool, optional
            Build under AddressSanitizer + UndefinedBehaviorSanitizer (any finding aborts).
        compiler : str, optional
            Default :func:`~fl_design.codegen.find_compiler` (e.g. ``"clang"``).

        Returns
        -------
        pathlib.Path

        Raises
        ------
        CompilerNotFoundError
            No C compiler.
        CompilationError
            The strict compile failed (the message has the compiler's output).

        Examples
        --------
        >>> from fl_design import presets
        >>> from fl_design.codegen import generate_c
        >>> generate_c(presets.paper_design(), "pb").build().name.startswith("fl_main")
        True
        """
        cc = compiler_or_raise(compiler)
        build = self.out_dir / "build"
        build.mkdir(exist_ok=True)
        exe = build / f"{self.prefix}_main{'_san' if sanitize else ''}_{Path(cc).name}"
        srcs = [str(self.out_dir / "main.c"), *map(str, self.sources)]
        run_command([cc, *self.flags(sanitize=sanitize), "-o", str(exe), *srcs, "-lm"],
                    what=f"compiling the {self.precision} harness with {cc}")
        return exe

    def run(self, y, r, *, executable: Path | None = None, env=None,
            start: bool = False) -> np.ndarray:
        """Feed ``y, r`` samples to the compiled harness; the inputs ``u`` it prints.

        Parameters
        ----------
        y, r : array_like
            ``(N,)`` measurements (NaN and inf allowed: see the rejection policy) and
            references.
        executable : path-like, optional
            A harness from :meth:`build` (default: build one).
        env : dict, optional
            Environment of the process (e.g. sanitizer options).
        start : bool, optional
            True: ``PREFIX_start`` at the first ``y`` and the operating point's input
            (``main.c``'s default, as firmware starts); False (default): from
            ``PREFIX_init``'s state, :meth:`Design.initial_state` (``main.c --init``).

        Returns
        -------
        numpy.ndarray
            ``(N,)`` inputs.

        Examples
        --------
        >>> from fl_design import presets
        >>> from fl_design.codegen import generate_c
        >>> generate_c(presets.paper_design(), "pr").run([float("nan")], [0.0])
        array([0.])
        """
        y, r = np.ravel(np.asarray(y, dtype=float)), np.ravel(np.asarray(r, dtype=float))
        if y.shape != r.shape:
            raise ParameterError(f"y and r must have the same length, got {y.size} and {r.size}")
        exe = executable or self.build()
        lines = "\n".join(f"{a!r} {b!r}" for a, b in zip(y.tolist(), r.tolist())) + "\n"
        out = run_command([str(exe)] + ([] if start else ["--init"]), what=f"the harness {exe}",
                          stdin=lines, env=env, timeout=600)
        return np.array(out.split(), dtype=float)

    def verify(self, plant, scenario, *, integrator=None, compiler=None, telemetry=None,
               excitation=None):
        """Software-in-the-loop: the compiled step drives the simulated plant in closed loop.

        See :func:`fl_design.codegen.software_in_the_loop`.

        Parameters
        ----------
        plant : Plant
            The plant (integrated with RK4, ``ClosedLoop.plant_step``).
        scenario : Scenario
            Reference, duration, initial state, noise, quantization.
        integrator : RK4, optional
            The plant's fixed-step integrator (default ``fl.RK4()``).
        compiler : str, optional
            C compiler.
        telemetry, excitation : optional
            A file for the C loop's telemetry frames; the firmware excitation as the
            reference (see :func:`~fl_design.codegen.software_in_the_loop`).

        Returns
        -------
        SilResult

        Examples
        --------
        >>> import fl_design as fl
        >>> from fl_design import presets
        >>> pkg = fl.generate_c(presets.paper_design(), "pv")
        >>> res = pkg.verify(fl.plants.trms_yaw(), fl.Scenario(0.3, 0.5))
        >>> res.matches, res.max_rel_error <= 1e-12, res.c_status == res.sim_status
        (True, True, True)
        """
        from ._sil import software_in_the_loop

        return software_in_the_loop(self, plant, scenario, integrator=integrator,
                                    compiler=compiler, telemetry=telemetry,
                                    excitation=excitation)

    def pil(self, plant, scenario, *, max_samples: int = 2000, timeout: float = 300,
            cflags=()):
        """Processor-in-the-loop on a Cortex-M4F model (QEMU ``mps2-an386``): u and its cost.

        Parameters
        ----------
        plant, scenario, max_samples, timeout, cflags
            As in :func:`fl_design.codegen.processor_in_the_loop`, which this calls with
            this package: the recorded run's plant and scenario, the samples fed (default
            2000), QEMU's time limit (s), extra flags of the package's sources.

        Returns
        -------
        PilResult

        Examples
        --------
        >>> import fl_design as fl
        >>> from fl_design import presets
        >>> from fl_design.codegen._pil import pil_tools
        >>> pkg = fl.generate_c(presets.paper_design(), "ppil", precision="float")
        >>> pil_tools()[2] != "" or pkg.pil(fl.plants.trms_yaw(), fl.Scenario(0.3, 0.1)).passed
        True
        """
        from ._pil import processor_in_the_loop

        return processor_in_the_loop(self, plant, scenario, max_samples=max_samples,
                                     timeout=timeout, cflags=cflags)

    def saturation_episode(self, plant, reference: float, **options):
        """The SIL's saturation episode: ``u`` pinned at its limit, released, the recovery.

        Parameters
        ----------
        plant, reference, **options
            As in :func:`fl_design.codegen._episode.saturation_episode`, which this calls
            with this package: the plant, the constant reference, and ``x0``, ``at``,
            ``pinned`` (default 10 s), ``within`` (default 3 s), ``after``.

        Returns
        -------
        SaturationEpisode
            Seconds pinned and recovery in C and in Python; ``passed``.

        Examples
        --------
        >>> import fl_design as fl
        >>> from fl_design import presets
        >>> pkg = fl.generate_c(presets.paper_design(gamma=0.1), "pse")
        >>> e = pkg.saturation_episode(fl.plants.trms_yaw(), 0.3, x0=[0.3, 0.0], pinned=1.0)
        >>> e.pinned_c == e.pinned_py
        True
        """
        from ._episode import saturation_episode

        return saturation_episode(self, plant, reference, **options)

    def cost(self, *, name: str | None = None, bench_steps: int = 2_000_000, compiler=None):
        """Operations per step, stack, code size and time per step (:class:`StepCost`).

        Parameters
        ----------
        name, bench_steps, compiler
            As in :func:`fl_design.codegen.step_cost`, which this calls with this package:
            the row's name, the steps of the timing run, the C compiler.

        Returns
        -------
        StepCost

        Examples
        --------
        >>> from fl_design import presets
        >>> from fl_design.codegen import generate_c
        >>> c = generate_c(presets.paper_design(), "pc").cost(bench_steps=1000)
        >>> c.flops > 0 and c.stack_bytes > 0
        True
        """
        from ._cost import step_cost

        return step_cost(self, name=name, bench_steps=bench_steps, compiler=compiler)


__all__ = ["FLOAT_WARNINGS", "SANITIZE_FLAGS", "CPackage", "compiler_or_raise", "run_command"]
