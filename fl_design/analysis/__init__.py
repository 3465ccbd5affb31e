"""Analysis layer: the sampled loop linearized, eps* from eigenvalues, and certificates.

Modules: ``_linearization`` (:func:`sampled_linearization`, :func:`linearized_eps_star`),
``_surrogate`` (the linear surrogate loop, affine in ``b``), ``_lmi`` (delta-form vertex LMIs:
Clarabel on the LMI's coefficients through ``_sdp``, CVXPY + SCS fallback, NumPy re-check),
``_cert_loop`` (the surrogate loop over a ``b`` interval: frozen checks, point certificates),
``_certify`` (:func:`certify_eps`), ``_curve`` (:func:`eps_star_curve`), ``_gamma`` (:func:`certify_gamma`), ``_coverage`` (eps* brackets
``[certified, refuted]`` per coverage: frozen, varying, rate-bounded, nonlinear), ``_refute``
(switching counterexamples), ``_ldi`` (the linear differential inclusion
with Jacobian bounds), ``_lyapunov`` (:func:`certify_lyapunov`, :func:`synthesize_gains`),
``_intervals`` (interval enclosures of SymPy expressions), ``_plant_bounds`` (``b``,
``d sigma/d xi`` and ``b``'s rate over a region and a parameter box, :func:`plant_bounds`),
``_region`` (the largest region where the nonlinear certificate holds and the initial states
it covers, :func:`nonlinear_region`), ``_margins`` (gain, phase and delay margins at the plant input,
:func:`loop_margins`), ``_noise`` (:func:`noise_gain`), ``_theorem1`` (Theorem 1's constants, :func:`theorem1_constants`), ``_cert_results``
(the result objects, each naming the class it certifies; an
:class:`~fl_design.analysis._cert_results.EpsBracket`
is returned inside them, not exported), ``_sos`` (the quartic SOS certificate for b varying in
time), ``_covered_lmi`` (the P chosen for the widest covered initial states), ``_plant_class``
(:class:`~fl_design.PlantClass`, what a certificate covers), ``_slope_structure``
(slope-restricted static functions of one coordinate), ``_class_resolve`` (a plant, plant
bounds or ``b`` range read as the class certified), ``_class_bracket`` (a slope-box class's
bracket: LDI certified, refuted by frozen corners and corner switching), ``_class_region``
(the largest certifiable region of a plant, opt-in). A layer exports
at most 20 names: :class:`PointCertificate` (inside every eps and gamma certificate's
``point``) and :class:`NonlinearRegion` (what :func:`nonlinear_region` returns) stay importable
from here but are not in ``__all__``.

Examples
--------
>>> from fl_design.analysis import SampledLinearization, certify_eps
>>> SampledLinearization.__name__, certify_eps.__name__
('SampledLinearization', 'certify_eps')
"""

from ._cert_results import EpsCertificate, GammaCertificate
from ._cert_results import PointCertificate as PointCertificate  # importable, not in __all__
from ._certify import certify_eps
from ._curve import eps_star_curve
from ._curve_result import EpsStarCurve
from ._gamma import certify_gamma
from ._linearization import SampledLinearization, linearized_eps_star, sampled_linearization
from ._lyapunov import GainSynthesis, LyapunovCertificate, certify_lyapunov, synthesize_gains
from ._margins import LoopMargins, loop_margins
from ._noise import noise_gain
from ._plant_bounds import plant_bounds
from ._region import NonlinearRegion as NonlinearRegion  # importable, not in __all__
from ._region import nonlinear_region
from ._theorem1 import Theorem1Constants, theorem1_constants

__all__ = [
    "EpsCertificate",
    "EpsStarCurve",
    "GainSynthesis",
    "GammaCertificate",
    "LoopMargins",
    "LyapunovCertificate",
    "SampledLinearization",
    "Theorem1Constants",
    "certify_eps",
    "certify_gamma",
    "certify_lyapunov",
    "eps_star_curve",
    "linearized_eps_star",
    "loop_margins",
    "noise_gain",
    "nonlinear_region",
    "plant_bounds",
    "sampled_linearization",
    "synthesize_gains",
    "theorem1_constants",
]
