"""The estimator interface of a :class:`~fl_design.Design`, and the one ``replace`` rule.

An estimator turns the measurements into ``xhat_ext = [xhat_1 .. xhat_rho, sigmahat]`` (steps 1
and 7 of the normative loop). Two implement it: the extended high-gain observer
(:class:`~fl_design.EHGO`) and the least-squares baseline
(:class:`~fl_design.LeastSquaresEstimator`). :class:`Estimator` declares what a design needs;
``Design`` checks ``isinstance(estimator, Estimator)`` instead of probing attributes.

Every frozen option object of the design layer changes its fields through
:func:`replace_fields`: unknown field names raise :class:`~fl_design.errors.ParameterError`
naming the valid ones, and the copy is validated again on construction.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.design import Estimator
>>> isinstance(fl.EHGO(rho=2, eps=0.05, T=1e-3), Estimator)
True
>>> fl.LeastSquaresEstimator(rho=2, T=1e-3, window=9).has_time_constant
False
"""

from __future__ import annotations

import abc
import dataclasses

import numpy as np

from ..errors import DimensionError, ParameterError


def replace_fields(obj, changes: dict, *, hint: str = ""):
    """``dataclasses.replace(obj, **changes)`` with a clear error for unknown field names.

    Parameters
    ----------
    obj : dataclass instance
        A frozen, validated-on-construction object.
    changes : dict
        New values of init fields.
    hint : str, optional
        Appended to the error message (e.g. why a field does not exist).

    Returns
    -------
    object
        A new, re-validated instance.

    Raises
    ------
    ParameterError
        A name in ``changes`` is not an init field of ``obj``.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.design import replace_fields
    >>> replace_fields(fl.EHGO(2, 0.05, 1e-3), {"eps": 0.1}).alpha
    0.01
    """
    valid = {f.name for f in dataclasses.fields(obj) if f.init}
    unknown = set(changes) - valid
    if unknown:
        raise ParameterError(
            f"{type(obj).__name__} has no field(s) {sorted(unknown)}{hint}; valid fields: "
            f"{sorted(valid)}"
        )
    return dataclasses.replace(obj, **changes)


class Estimator(abc.ABC):
    """What a :class:`~fl_design.Design` needs of an estimator (abstract base).

    Implementations are frozen dataclasses with at least the fields ``rho`` (relative degree
    served) and ``T`` (sampling time). ``has_time_constant`` says whether the estimator has an
    observer time constant ``eps`` that a sweep may change.

    Examples
    --------
    >>> from fl_design.design import Estimator
    >>> sorted(Estimator.__abstractmethods__)  # doctest: +NORMALIZE_WHITESPACE
    ['flops_per_step', 'initial_state', 'parameter_vector', 'state_size', 'symbolic_update']
    """

    #: True when the estimator has a time constant ``eps`` (the EHGO).
    has_time_constant: bool = False
    rho: int
    T: float

    @property
    @abc.abstractmethod
    def state_size(self) -> int:
        """Length of the estimator state."""

    @property
    @abc.abstractmethod
    def flops_per_step(self) -> int:
        """Multiply-adds per sample."""

    @abc.abstractmethod
    def initial_state(self, *, y0: float | None = None, estimate=None, params=None) -> np.ndarray:
        """The estimator state before the first sample (bumpless: at rest at ``y0``).

        ``estimate`` (length ``rho + 1``: ``y, y', ..., sigma``) overrides the start;
        ``params`` is a parameter vector of this estimator's family (default its own).
        """

    @abc.abstractmethod
    def parameter_vector(self) -> np.ndarray:
        """Every number the step depends on that a sweep may change (a flat vector)."""

    @abc.abstractmethod
    def symbolic_update(self, xi, y, p):
        """``(xhat_ext, xi_next, ready)`` as CasADi expressions (loop steps 1 and 7)."""

    def replace(self, **changes):
        """A copy with fields changed, validated again (unknown fields: ParameterError).

        Parameters
        ----------
        **changes
            New values of the estimator's fields.

        Returns
        -------
        Estimator
            Of the same class.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.LeastSquaresEstimator(rho=2, T=1e-3, window=9).replace(window=26).window
        26
        """
        hint = "" if self.has_time_constant else (
            f" ({type(self).__name__} has no eps: its time scale is set by its own fields)")
        return replace_fields(self, changes, hint=hint)


# --- CasADi helpers shared by the estimators ------------------------------------------------------
def as_casadi(x):
    """``x`` unchanged if it is a CasADi matrix, else a ``casadi.DM`` of it."""
    import casadi

    if isinstance(x, (casadi.SX, casadi.MX, casadi.DM)):
        return x
    return casadi.DM(np.asarray(x, dtype=float))


def check_length(name: str, x, n: int) -> None:
    """Raise DimensionError unless the CasADi matrix ``x`` is a vector of length ``n``."""
    if x.numel() != n or min(x.shape) > 1:
        raise DimensionError(f"{name} must be a vector of length {n}, got shape {x.shape}")


def checked_estimate(estimate, rho: int) -> np.ndarray:
    """``estimate`` as a vector of ``rho + 1`` finite floats, or a named DimensionError.

    Parameters
    ----------
    estimate : array_like
        ``(xhat_1, ..., xhat_rho, sigmahat)``.
    rho : int
        Relative degree.

    Returns
    -------
    numpy.ndarray
        ``(rho + 1,)`` floats.

    Examples
    --------
    >>> from fl_design.design._estimator import checked_estimate
    >>> checked_estimate([0.1, 0.0, 0.0], 2).tolist()
    [0.1, 0.0, 0.0]
    """
    from .. import _validate as v

    if np.ndim(estimate) != 1 or np.size(estimate) != rho + 1:
        raise DimensionError(
            f"initial_estimate must have rho + 1 = {rho + 1} entries (y, y', ..., "
            f"y^({rho - 1}), sigma), got {np.shape(estimate)} ({np.ravel(estimate).tolist()})")
    return v.real_vector("initial_estimate", estimate, length=rho + 1)


def rows(p, start: int, nrows: int, ncols: int):
    """Matrix stored row-major in ``p[start : start + nrows*ncols]`` (CasADi is column-major)."""
    import casadi

    return casadi.reshape(p[start : start + nrows * ncols], ncols, nrows).T


__all__ = ["Estimator", "as_casadi", "check_length", "checked_estimate", "replace_fields", "rows"]
