"""Design layer: estimators (EHGO, least squares), the dynamic controller, and the loop step.

Modules: ``_ehgo`` (:class:`EHGO`), ``_least_squares`` (:class:`LeastSquaresEstimator`),
``_controller`` (:class:`DynamicController`, gain helpers), ``_design`` (:class:`Design`, whose
``step`` is the one ``casadi.Function`` of the normative loop).

Examples
--------
>>> from fl_design.design import binomial_coeffs
>>> binomial_coeffs(2)
(3.0, 3.0, 1.0)
"""

from ._controller import DynamicController, gains_from_poles, lqr_gains
from ._design import Design, OpenLoopRun
from ._ehgo import EHGO, METHODS, StateSpaceMatrices, binomial_coeffs
from ._estimator import Estimator, replace_fields
from ._layout import Layout
from ._least_squares import LeastSquaresEstimator, derivative_matrix

__all__ = [
    "EHGO",
    "METHODS",
    "Design",
    "DynamicController",
    "Estimator",
    "Layout",
    "LeastSquaresEstimator",
    "OpenLoopRun",
    "StateSpaceMatrices",
    "binomial_coeffs",
    "derivative_matrix",
    "gains_from_poles",
    "lqr_gains",
    "replace_fields",
]
