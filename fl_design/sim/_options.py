"""Run options as frozen, validated objects: one TOML table each in a configuration.

* :class:`Scenario` - what is run: reference, duration, initial state, measurement
  :class:`Noise` and quantization;
* :class:`Classifier` - how a run is judged: tolerance, tail window, divergence bound;
* :class:`RK4` / :class:`Cvodes` - how the plant is integrated between samples;
* :class:`Kernel` - where it runs: compiled C or CasADi's interpreter, the compiled-kernel cache,
  threads and chunks of a sweep.

:func:`fl_design.simulate`, :func:`fl_design.sweep` and :func:`fl_design.estimate_eps_star`
take these objects; no option is re-declared or forwarded by hand. Every object is valid the
moment it exists and keeps the values given (normalized values are derived when a run is
prepared, where the sampling time is known).

Examples
--------
>>> import fl_design as fl
>>> sc = fl.Scenario(0.3, 20.0, noise=fl.Noise(std=1e-3, seed=1))
>>> sc.n_samples(1e-3), sc.noise.std
(20000, 0.001)
>>> fl.Classifier().tolerance, fl.RK4().substeps
(0.02, None)
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as V
from .._json import jsonable
from .._limits import check_substeps
from ..errors import ParameterError
from ._scenario import Noise, Scenario


@dataclass(frozen=True)
class Classifier:
    """How a run is judged: settling band, tail window and divergence bound.

    Parameters
    ----------
    tolerance : float, optional
        Relative tolerance of the settling band (default 0.02): ``tol = tolerance * scale``
        with ``scale = max(|step|, peak-to-peak of r)`` (1 output unit when both vanish).
    tail_fraction : float, optional
        Fraction of the run, at its end, used for the tail metrics, in (0, 1] (default 0.2).
    divergence_bound : float or array_like, optional
        Bound on ``|x - x_op|`` per state beyond which a run is diverged (default: 10 x the
        region's width per state, else 1e6; see :meth:`bound_for`).

    Raises
    ------
    ParameterError
        A non-positive tolerance or bound, a tail fraction outside (0, 1].

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.Classifier(tolerance=0.05).tail_fraction
    0.2
    """

    tolerance: float = 0.02
    tail_fraction: float = 0.2
    divergence_bound: Any = None

    def __post_init__(self) -> None:
        V.positive("tolerance", self.tolerance)
        tail = V.real_scalar("tail_fraction", self.tail_fraction)
        if not 0.0 < tail <= 1.0:
            raise ParameterError(f"tail_fraction must be in (0, 1], got {tail!r}")
        bound = self.divergence_bound
        if bound is not None:
            if np.ndim(bound) == 0:
                V.positive("divergence_bound", bound)
            else:
                arr = V.real_vector("divergence_bound", bound)
                if np.any(arr <= 0):
                    raise ParameterError(f"divergence_bound must be > 0, got {arr.tolist()}")

    def bound_for(self, plant) -> np.ndarray:
        """Per-state bound on ``|x - x_op|`` for ``plant``: as given, or 10 x the region's width.

        By default a run whose state leaves this box is *diverged* (it has left the region of
        interest ten times over: no controller of that region is working any more); states
        without a region get a large absolute bound, 1e6, that only catches escapes.

        Parameters
        ----------
        plant : Plant
            Its ``n`` states and their region.

        Returns
        -------
        numpy.ndarray
            One bound on ``|x_i - x_op,i|`` per state, ``(n,)``.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Classifier().bound_for(fl.plants.pendulum()).round(2).tolist()
        [62.83, 200.0]
        >>> fl.Classifier(divergence_bound=2.0).bound_for(fl.plants.pendulum()).tolist()
        [2.0, 2.0]
        """
        bound = self.divergence_bound
        if bound is None:
            ranges = plant._state_ranges()[0].values()  # without SymPy (a cached plant)
            return np.array([1e6 if r is None else 10.0 * (r[1] - r[0]) for r in ranges])
        if np.ndim(bound) == 0:
            return np.full(plant.n, float(bound))
        return V.real_vector("divergence_bound", bound, length=plant.n)

    def k_tail(self, N: int) -> int:
        """First sample of the tail window of a run of ``N`` samples.

        Parameters
        ----------
        N : int
            Samples in the run.

        Returns
        -------
        int
            ``min(N - 1, floor((1 - tail_fraction) N))``.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Classifier().k_tail(1000)
        800
        """
        return min(N - 1, math.floor((1.0 - float(self.tail_fraction)) * N))

    def to_dict(self) -> dict:
        """Strict-JSON fields.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Classifier().to_dict()["tolerance"]
        0.02
        """
        return {"tolerance": float(self.tolerance), "tail_fraction": float(self.tail_fraction),
                "divergence_bound": jsonable(self.divergence_bound)}


@dataclass(frozen=True)
class RK4:
    """Fixed-step classical Runge-Kutta between samples, the input held (zero-order hold).

    Parameters
    ----------
    substeps : int, optional
        RK4 steps per sample (>= 1; default :func:`fl_design.sim.kernel.default_substeps`, from the
        plant's fastest linearized mode).

    Raises
    ------
    ParameterError
        ``substeps`` not a positive integer.
    ResourceLimitError
        ``substeps`` above ``$FL_DESIGN_MAX_SUBSTEPS`` (default 10000: the work per sample and
        the compiled kernel's work arrays grow with it).

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.RK4(substeps=4).substeps
    4
    """

    substeps: int | None = None

    def __post_init__(self) -> None:
        if self.substeps is not None:
            check_substeps(self.substeps)

    def to_dict(self) -> dict:
        """Strict-JSON fields.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.RK4().to_dict()
        {'method': 'rk4', 'substeps': None}
        """
        return {"method": "rk4", "substeps": self.substeps}


@dataclass(frozen=True)
class Cvodes:
    """CasADi's adaptive ``cvodes`` (BDF) sample by sample: the slow reference integrator.

    Parameters
    ----------
    reltol, abstol : float, optional
        Tolerances (default 1e-10, 1e-12).
    max_num_steps : int, optional
        Internal step budget per sample (default 20000).

    Raises
    ------
    ParameterError
        Non-positive tolerances or step budget.

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.Cvodes().reltol
    1e-10
    """

    reltol: float = 1e-10
    abstol: float = 1e-12
    max_num_steps: int = 20000

    def __post_init__(self) -> None:
        V.positive("reltol", self.reltol)
        V.positive("abstol", self.abstol)
        V.integer("max_num_steps", self.max_num_steps, minimum=1)

    def to_dict(self) -> dict:
        """Strict-JSON fields.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Cvodes().to_dict()["method"]
        'cvodes'
        """
        return {"method": "cvodes", "reltol": float(self.reltol), "abstol": float(self.abstol),
                "max_num_steps": int(self.max_num_steps)}


@dataclass(frozen=True)
class Kernel:
    """Where runs execute: compiled C (cached) or CasADi's interpreter, threads and chunks.

    Parameters
    ----------
    compiled : bool, optional
        Generated C, compiled once and cached (default True; falls back to the interpreter
        with a :class:`~fl_design.errors.CompilationWarning` when no compiler works).
    cache_dir : path-like, optional
        Cache of compiled kernels (default ``$FL_DESIGN_CACHE``, else
        ``$XDG_CACHE_HOME/fl_design``, else ``~/.cache/fl_design``).
    threads : int, optional
        Threads per process of a sweep (default: the cores available; 1 per task with an
        executor).
    chunk_size : int, optional
        Grid points per chunk/task of a sweep. In this process (default
        :data:`fl_design.sim.CHUNK_IN_PROCESS` = 256; with several threads the first and the
        last chunk a quarter of that, their Python work being the part not overlapped with
        the kernel) a chunk only sets how often the progress bar moves; each chunk costs a
        few milliseconds of Python and a thread rendezvous, so chunks of 256 made a 64 x 64
        TRMS map 0.3 s faster than chunks of 64. With an
        executor the default deals the grid out strided to 4 tasks per worker (at least 16
        runs each; :mod:`fl_design.sim._executor`), so every worker gets a fair mix of cheap
        diverging and full-length runs and one payload covers many runs.
    lanes : bool, optional
        Sweeps run several grid points per SIMD vector (the lanes kernel, default True) or
        one at a time (the scalar kernel).
    vector_math : bool, optional
        Lanes kernel with glibc libmvec's vector ``tanh``/``sin``/``exp`` (default, unless
        ``$FL_DESIGN_VECTOR_MATH=0``) or glibc's scalar functions (False). Scalar math gives
        bit for bit the results of the scalar kernel and of CasADi's interpreter (tested on
        every test grid), but a scalar call per lane costs 4.35x on the TRMS loop (31 -> 133 ns
        per step, one thread, ``verify/bench_sweep.py`` at load 1.1). libmvec's functions differ from glibc's scalar ones
        by 1-3 ulp on 27-34 % of ``tanh`` arguments in [-5, 5] and 60 % of ``sin`` arguments;
        the closed loop carries these last bits along, so the default is not bitwise. Measured
        against the interpreter (and ``vector_math=False``): every run of the test grids and
        of the TRMS benchmark maps (32 x 32 x 5 s, 64 x 64 x 20 s) has the same classification
        and divergence sample; metrics agree to 1e-10 relative on the test grids (1.6e-11 on
        the pendulum's eps* grid) and, on the 64 x 64 TRMS map, to 5e-10 of each metric's
        median value (2e-12 rad absolute on the error metrics; relative differences reach
        1.6e-5 only on steady-state errors of 3e-8 rad). Choose False when results must
        be reproducible bit for bit.
    isa : str, optional
        Instruction-set level of the lanes kernel: ``"avx512"`` (8 lanes), ``"avx2"`` (4),
        ``"sse2"`` or ``"neon"`` (2), ``"portable"`` (2, no ISA flags), ``"scalar"`` (the
        scalar compiled kernel, one run at a time) or ``"native"``. Default
        ``$FL_DESIGN_ISA``, else the widest level this CPU has (read at run time, never
        assumed; :meth:`describe` says which). A level the CPU lacks is refused.

    Raises
    ------
    ParameterError
        ``compiled`` not a bool, ``threads`` or ``chunk_size`` not a positive integer, ``isa``
        unknown or not available on this machine.

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.Kernel(compiled=False).compiled
    False
    """

    compiled: bool = True
    cache_dir: Any = None
    threads: int | None = None
    chunk_size: int | None = None
    lanes: bool = True
    vector_math: bool | None = None
    isa: str | None = None

    def __post_init__(self) -> None:
        V.boolean("compiled", self.compiled)
        V.boolean("lanes", self.lanes)
        if self.vector_math is not None:
            V.boolean("vector_math", self.vector_math)
        if self.threads is not None:
            V.integer("threads", self.threads, minimum=1)
        if self.chunk_size is not None:
            V.integer("chunk_size", self.chunk_size, minimum=1)
        if self.isa is not None:
            from .._isa import resolve_isa

            resolve_isa(self.isa)  # unknown or unavailable: a clear ParameterError now

    def describe(self) -> dict:
        """What this kernel runs on: the machine, the chosen instruction set and why.

        Returns
        -------
        dict
            Strict JSON: ``cpu``, ``machine``, ``compiler``, ``lanes_compiler`` (the one the
            sweeps' lanes kernel is built with: clang when ``$CC`` is unset and clang is on the
            ``PATH``, else ``compiler``; a clang that fails falls back to ``compiler``; None
            without lanes), ``isa`` (the level sweeps use),
            ``lanes`` (grid points per vector; 1 for the scalar kernel, 0 interpreted),
            ``isa_source`` (``fl.Kernel(isa=...)``, ``$FL_DESIGN_ISA`` or widest available),
            ``available`` (levels this machine can run), ``vector_math`` (libmvec functions
            used, empty with ``vector_math=False``) and ``compiled``.

        Examples
        --------
        >>> import fl_design as fl
        >>> info = fl.Kernel(isa="scalar").describe()
        >>> info["isa"], info["lanes"]
        ('scalar', 1)
        """
        import platform

        from .._isa import ISA_ENV, available_isas, cpu_model, resolve_isa
        from .._toolchain import find_compiler
        from .kernel._lanes import preferred_compiler, vector_math

        isa = resolve_isa(self.isa if self.lanes else "scalar")
        compiled = bool(self.compiled) and find_compiler() is not None
        use_mvec = self.vector_math
        if use_mvec is None:
            from .._limits import env_flag

            use_mvec = env_flag("FL_DESIGN_VECTOR_MATH", True)
        source = ("fl.Kernel(isa=...)" if self.isa is not None
                  else f"${ISA_ENV}" if os.environ.get(ISA_ENV, "").strip()
                  else "widest available")
        return {"cpu": cpu_model(), "machine": platform.machine(),
                "compiler": find_compiler(), "compiled": compiled,
                "lanes_compiler": (preferred_compiler() or find_compiler())
                if compiled and self.lanes and isa.lanes else None,
                "isa": isa.name if compiled else "interpreted",
                "lanes": isa.width if compiled else 0,
                "isa_source": source if self.lanes else "fl.Kernel(lanes=False)",
                "available": list(available_isas()),
                "vector_math": list(vector_math(isa)) if compiled and use_mvec else []}

    def to_dict(self) -> dict:
        """Strict-JSON fields.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.Kernel().to_dict()["compiled"]
        True
        """
        return {"compiled": bool(self.compiled),
                "cache_dir": None if self.cache_dir is None else str(self.cache_dir),
                "threads": self.threads, "chunk_size": self.chunk_size, "lanes": self.lanes,
                "vector_math": self.vector_math, "isa": self.isa}


def option(name: str, value, cls, *, default=None, what: str | None = None):
    """An option object as given, its default when None, else a clear ParameterError.

    The one check behind every ``integrator=``, ``classifier=``, ``kernel=`` and ``scenario``
    argument of :func:`fl_design.simulate`, :func:`fl_design.sweep` and their helpers.

    Parameters
    ----------
    name : str
        The argument's name.
    value : object
        What was given (None: the default).
    cls : type or tuple of types
        Accepted classes.
    default : callable, optional
        Builds the default (default ``cls()``; None with no default means required).
    what : str, optional
        What is expected, in words (default ``"a fl.<cls>"``).

    Returns
    -------
    object
        ``value``, or the default built when it is None.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._options import option
    >>> option("kernel", None, fl.Kernel).compiled
    True
    """
    if value is None:
        value = (default or cls)()
    return V.instance(name, value, cls, what or f"a fl.{cls.__name__}")


__all__ = ["RK4", "Classifier", "Cvodes", "Kernel", "Noise", "Scenario"]
