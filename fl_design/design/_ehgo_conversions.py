"""Other views of an EHGO: its continuous model, python-control object, unscaled outputs, and a
NumPy filter over logged samples (:class:`fl_design.EHGO` inherits these from :class:`EHGOViews`).

Examples
--------
>>> import numpy as np, fl_design as fl
>>> fl.EHGO(1, 0.1, 1e-3).filter(np.ones(3)).shape
(3, 2)
"""

from __future__ import annotations

import numpy as np

from .. import _validate as v
from ..errors import MissingDependencyError
from ._ehgo_discretization import StateSpaceMatrices, _lsim_blocked


class EHGOViews:
    """Representations of an EHGO other than its loop step (mixed into :class:`fl_design.EHGO`).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.design._ehgo_conversions import EHGOViews
    >>> isinstance(fl.EHGO(1, 0.1, 1e-3), EHGOViews)
    True
    """

    def continuous(self) -> StateSpaceMatrices:
        """The unscaled continuous observer ``(A - H C, H, I, 0)``, input y, output xhat_ext.

        Returns
        -------
        StateSpaceMatrices
            ``A - H C`` with ``A`` the chain of ``rho + 1`` integrators, ``C = e_1^T``, and
            ``H_i = alpha_i / eps^i`` (badly scaled for small eps: that is why the discrete
            observer is built in scaled coordinates).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.EHGO(1, 0.5, 1e-3, coeffs=(3, 2)).continuous().B.ravel()
        array([6., 8.])
        """
        n = self.state_size
        H = self.gains.reshape(n, 1)
        A = np.eye(n, k=1)
        A[:, 0] -= H[:, 0]
        return StateSpaceMatrices(A, H, np.eye(n), np.zeros((n, 1)))

    def output_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """``(D^-1 C_d, D^-1 D_d)``: the map ``(xi_k, y_k) -> xhat_k`` in unscaled units."""
        d = self.unscaling.reshape(-1, 1)
        return d * self._mats.C, d * self._mats.D

    def to_statespace(self):
        """python-control ``StateSpace`` (dt = T) from y to the unscaled ``xhat_ext``.

        Returns
        -------
        control.StateSpace
            ``rho + 1`` outputs: ``y, y', ..., y^(rho-1), sigma`` estimates.

        Raises
        ------
        MissingDependencyError
            python-control is not installed (``pip install fl_design[control]``).

        Examples
        --------
        >>> import fl_design as fl
        >>> sys = fl.EHGO(2, 0.05, 1e-3).to_statespace()
        >>> sys.noutputs, sys.dt
        (3, 0.001)
        """
        try:
            import control
        except ImportError:
            raise MissingDependencyError(
                "EHGO.to_statespace needs python-control: pip install fl_design[control]"
            ) from None
        C, D = self.output_matrices()
        return control.StateSpace(self._mats.A, self._mats.B, C, D, dt=self.T)

    # --- numpy convenience -------------------------------------------------------------------
    def filter(self, y_samples, *, xi0=None) -> np.ndarray:
        """Run the observer over measured samples (exactly the loop's steps 1 and 7).

        Parameters
        ----------
        y_samples : array_like, shape (N,)
            Measurements ``y_0 .. y_(N-1)`` taken every ``T``.
        xi0 : array_like, optional
            Initial observer state; default :meth:`initial_state`.

        Returns
        -------
        numpy.ndarray, shape (N, rho+1)
            ``xhat_k`` (unscaled) for every sample.

        Examples
        --------
        >>> import numpy as np, fl_design as fl
        >>> fl.EHGO(1, 0.1, 1e-3).filter(np.ones(5000))[-1].round(6)
        array([1., 0.])
        """
        y = v.real_vector("y_samples", np.ravel(y_samples) if np.ndim(y_samples) else y_samples)
        n = self.state_size
        x0 = np.zeros(n) if xi0 is None else v.real_vector("xi0", xi0, length=n)
        C, D = self.output_matrices()
        return _lsim_blocked(self._mats.A, self._mats.B, C, D, y, x0)


__all__ = ["EHGOViews"]
