"""Analysis layer: the sampled loop linearized at its equilibrium, eps* from eigenvalues.

Modules: ``_linearization`` (:func:`sampled_linearization`, :func:`linearized_eps_star`).

Examples
--------
>>> from fl_design.analysis import SampledLinearization
>>> SampledLinearization.__name__
'SampledLinearization'
"""

from ._linearization import SampledLinearization, linearized_eps_star, sampled_linearization

__all__ = ["SampledLinearization", "linearized_eps_star", "sampled_linearization"]
