"""Tuning layer: a design proposed from the plant alone, certified and checked.

Modules: ``_tune`` (:func:`tune`: time scale, T, objectives, the result), ``_candidate``
(one candidate loop: gains, gamma, eps, and the chosen loop's certified eps and phase margin,
each failing step with its fallback), ``_check`` (the check simulation, the runs around the
design, the noise gain, the baseline),
``_tuning`` (:class:`Tuning`, the result). It sits above ``analysis`` and ``sim`` (it needs
the certificates and a simulation) and below ``app``.

Examples
--------
>>> from fl_design.tuning import Tuning, tune
>>> tune.__name__, Tuning.__name__
('tune', 'Tuning')
"""

from ._tune import tune
from ._tuning import Tuning

__all__ = ["Tuning", "tune"]
