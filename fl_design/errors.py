"""Exceptions and warnings raised by fl_design.

Every error names the offending value and says what would be valid. Each class subclasses a
builtin (``ValueError`` for bad input, ``RuntimeError`` for failures while computing) so that
callers can catch either the precise class or the builtin.

Examples
--------
>>> import fl_design as fl
>>> try:
...     fl.EHGO(rho=2, eps=-1.0, T=1e-3)
... except fl.errors.ParameterError as err:
...     print(type(err).__mro__[1].__name__, "ValueError" in [c.__name__ for c in type(err).__mro__])
FlDesignError True
"""

from __future__ import annotations


class FlDesignError(Exception):
    """Base class of every exception raised by fl_design."""


# --- bad input (ValueError) -------------------------------------------------------------------
class ParameterError(FlDesignError, ValueError):
    """A numeric parameter is out of range, non-finite or of the wrong type."""


class DimensionError(ParameterError):
    """An array or sequence has the wrong length or shape."""


class HurwitzError(ParameterError):
    """A polynomial that must be Hurwitz has roots outside the open left half-plane."""


class PlantDefinitionError(FlDesignError, ValueError):
    """A plant's symbolic definition is inconsistent (unknown symbols, shapes, missing input...)."""


class RelativeDegreeError(FlDesignError, ValueError):
    """The relative degree is not defined (input coefficient vanishes, or input never appears)."""


class DesignMismatchError(FlDesignError, ValueError):
    """Parts that must agree do not (observer vs controller order, plant vs design relative degree)."""


class OutputPathError(FlDesignError, ValueError):
    """An output folder cannot be created or written (it names the folder and the reason)."""


class ResourceLimitError(FlDesignError, ValueError):
    """The requested work or memory exceeds a limit; the message names it and how to lift it."""


# --- failures while computing (RuntimeError) ---------------------------------------------------
class ComputationError(FlDesignError, RuntimeError):
    """A computation could not be carried out (solver failure, compiler missing, ...)."""


class CompilerNotFoundError(ComputationError):
    """No C compiler (or cross-compiler) is installed where one is needed."""


class CompilationError(ComputationError):
    """Generated C code failed to compile (the compiler's message is included)."""


class CertificationError(ComputationError):
    """A certificate was asked to hold (``raise_on_failure=True``) and does not."""


class WorkerLostError(ComputationError):
    """A worker of an executor died (or hung) while it ran part of a grid.

    The finished chunks are not lost: :attr:`partial` is the result the call would have
    returned (a :class:`~fl_design.sim.StabilityMap`, :class:`~fl_design.sim.RobustMap` or
    :class:`~fl_design.sim.Ensemble`, of the subclass that marks what is missing), holding
    every finished run's status and metrics exactly as a complete run gives them; the lost
    runs are ``undecided`` with NaN metrics, flagged in its ``lost`` mask, with the reason
    ``"worker lost"`` (:data:`LOST_REASON`) in its ``lost_reason``.

    Attributes
    ----------
    lost : list of int
        Flat (row-major) indices of the lost runs in the result the caller asked for
        (eps-major for a map; sample fastest for a robust map).
    partial : object or None
        The partial result (None when no result type applies, e.g. an internal grid).
    accumulators : numpy.ndarray or None
        The grid's final accumulators, the lost columns NaN (for internal use).
    workers : list of str
        The workers named dead or stuck (``"worker process 1234 (killed by signal 9)"``,
        ``"Dask worker tcp://...:4001"``); empty when the executor could not say.

    Examples
    --------
    >>> from fl_design.errors import WorkerLostError
    >>> err = WorkerLostError("lost", lost=[3, 1], workers=["worker process 7 (exit code 1)"])
    >>> err.lost, err.partial, err.workers
    ([1, 3], None, ['worker process 7 (exit code 1)'])
    """

    def __init__(self, message: str, *, lost=(), partial=None, accumulators=None,
                 workers=()):
        super().__init__(message)
        self.lost = sorted(int(i) for i in lost)
        self.partial = partial
        self.accumulators = accumulators
        self.workers = list(workers)

    def with_partial(self, partial, lost=None) -> WorkerLostError:
        """This error, carrying ``partial`` (and the lost indices of that result).

        Returns
        -------
        WorkerLostError
            ``self`` (raise it again).
        """
        self.partial = partial
        if lost is not None:
            self.lost = sorted(int(i) for i in lost)
        return self


#: The reason a partial result gives for its missing runs (:class:`WorkerLostError`).
LOST_REASON = "worker lost"


class DerivationTimeoutError(ComputationError):
    """A symbolic derivation ran past its time budget (``$FL_DESIGN_DERIVE_SECONDS``)."""


class MissingDependencyError(FlDesignError, RuntimeError):
    """An optional dependency needed for the requested feature is not installed."""


# --- warnings --------------------------------------------------------------------------------
class UnstableDiscretizationWarning(UserWarning):
    """A discretization was built although its state matrix is not Schur stable."""


class CompilationWarning(UserWarning):
    """No C compiler (or compilation failed): a kernel runs in CasADi's interpreter instead."""


class CacheWarning(UserWarning):
    """A cached plant derivation was corrupted: it was recomputed and rewritten."""


class UnmodeledDynamicsWarning(UserWarning):
    """A design of lower relative degree than the plant's runs on it (opted in on purpose)."""


class NonMinimumPhaseWarning(UserWarning):
    """A loop is built on a plant whose zero dynamics are not asymptotically stable.

    The method assumes a minimum-phase plant: on one that is not, the output may still settle
    while the internal states leave the region, and no guarantee holds.
    """


class ExpressionError(PlantDefinitionError):
    """An expression string is outside the plant grammar (unknown name or function, attribute,
    call, too long, too deep, exponent too large); the message names the part and what is valid."""


class UnsafeCacheWarning(CacheWarning):
    """The cache folder is not private to the user (owner, group/world-writable): it is bypassed."""


class OutputExistsError(OutputPathError):
    """An output folder holds files fl_design did not write; refused unless ``force=True``."""


class UnsafeCacheError(ComputationError):
    """The cache folder (or its key) may have been written by someone else: it is not used."""


class PoorlyScaledWarning(UserWarning):
    """A structural decision is exact, but the plant's numbers are near double round-off there
    (e.g. the input's coefficient is below 1e-14 of the output derivative it enters)."""


__all__ = [
    "CacheWarning",
    "CertificationError",
    "CompilationError",
    "CompilationWarning",
    "CompilerNotFoundError",
    "ComputationError",
    "DerivationTimeoutError",
    "DesignMismatchError",
    "DimensionError",
    "ExpressionError",
    "FlDesignError",
    "HurwitzError",
    "MissingDependencyError",
    "NoDesignError",
    "NonMinimumPhaseWarning",
    "OutputExistsError",
    "OutputPathError",
    "ParameterError",
    "PlantDefinitionError",
    "PoorlyScaledWarning",
    "RelativeDegreeError",
    "ResourceLimitError",
    "UnmodeledDynamicsWarning",
    "UnsafeCacheError",
    "UnsafeCacheWarning",
    "UnstableDiscretizationWarning",
    "WorkerLostError",
]


class FloatPrecisionWarning(UserWarning):
    """A single-precision C build is predicted to miss its accuracy bound (codegen)."""


class PrecisionError(ParameterError):
    """``precision="float"`` refused: the single-precision build would miss its bound."""


__all__ += ["FloatPrecisionWarning", "PrecisionError"]


class NoDesignError(CertificationError):
    """No design with a certificate and a converging check exists for the data (fl.tune)."""


class LogError(ParameterError):
    """A rig's log that cannot be used as given (names the row or column and what is needed)."""


class ExcitationError(LogError):
    """A log that does not excite the loop enough to bound ``b`` (says which experiment would)."""


__all__ += ["ExcitationError", "LogError"]


class AssumptionError(FlDesignError, ValueError):
    """The plant is outside the method's assumptions (non-minimum phase, b changing sign)."""


__all__ += ["AssumptionError"]
