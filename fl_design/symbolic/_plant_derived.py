"""What a :class:`fl_design.Plant` derives: relative degree, normal form, CasADi functions, bounds.

The methods of :class:`Derivations` (a base of :class:`fl_design.Plant`): each quantity is
computed once per process and cached on disk by content (:mod:`._derivation_cache`); SymPy and
the deriving modules are imported only when a quantity is not in the cache.

Examples
--------
>>> import fl_design as fl
>>> fl.plants.pendulum().relative_degree()
2
"""

from __future__ import annotations

import warnings
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from .. import _validate as V
from ..errors import PoorlyScaledWarning
from ._casadi_functions import PlantFunctions

if TYPE_CHECKING:  # pragma: no cover - annotations only (the module imports SymPy)
    from ._normal_form import LieChain, NormalForm

# The derivations are imported on first use: a plant whose quantities are all in the cache (and
# a library plant, known by its recipe) never imports SymPy. Module-level names, so that tests
# can watch them.


def to_casadi(*args, **kw):
    from ._bridge import to_casadi as translate
    return translate(*args, **kw)


def lie_chain(plant):
    from ._normal_form import lie_chain as derive
    return derive(plant)


def derive_normal_form(plant):
    from ._normal_form import derive_normal_form as derive
    return derive(plant)


def b_bounds(plant, **kw):
    from ._normal_form import b_bounds as bound
    return bound(plant, **kw)


def _warn_notes(notes, stacklevel: int = 4) -> None:
    """A derivation's notes as :class:`~fl_design.errors.PoorlyScaledWarning` (also when read
    from the cache)."""
    for note in notes:
        warnings.warn(note, PoorlyScaledWarning, stacklevel=stacklevel)



class Derivations:
    """The derived quantities of a plant (methods of :class:`fl_design.Plant`; see there).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.symbolic._plant_derived import Derivations
    >>> isinstance(fl.plants.pendulum(), Derivations)
    True
    """

    def _derived(self, what: str, compute, check=None):
        """``what``, computed once per process and cached on disk by content (:mod:`._derivation_cache`)."""
        if what not in self._cache:
            self._cache[what] = self._store.get(what, compute, check)
        return self._cache[what]

    def _notes_once(self, notes) -> None:
        if not self._cache.get("warned"):
            self._cache["warned"] = True
            _warn_notes(notes, stacklevel=5)

    def _lie_chain(self) -> LieChain:
        from ._normal_form import LieChain

        chain = self._derived("chain", lambda: lie_chain(self), LieChain)
        self._notes_once(chain.notes)
        return chain

    def relative_degree(self) -> int:
        """The relative degree rho, by Lie derivatives along ``f(x, u)`` with u held constant.

        rho is the first i for which ``d y^(i)/du`` is not identically zero (checked at random
        points of the region, then symbolically); the input may enter non-affinely.

        Returns
        -------
        int

        Raises
        ------
        RelativeDegreeError
            If the input does not appear up to ``y^(n)``, or ``b = d y^(rho)/du`` vanishes at the
            operating point ``(x_op, u_eq)`` (the message names the point and ``b``).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.plants.flexible_joint().relative_degree()
        4
        """
        def derive() -> tuple:
            chain = self._lie_chain()
            return chain.rho, tuple(chain.notes)

        rho, notes = self._derived("rho", derive, tuple)  # no SymPy when read from the cache
        self._notes_once(notes)
        return rho

    def output_derivatives(self, order: int) -> tuple:
        """``(y, y', ..., y^(order))`` as SymPy expressions (Lie derivatives along ``f``).

        Parameters
        ----------
        order : int
            Highest derivative, ``0 <= order <= rho``; below ``rho`` none depends on the input.

        Returns
        -------
        tuple of sympy.Expr

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.plants.pendulum().output_derivatives(1)
        (theta, theta_dot)
        """
        chain = self._lie_chain()
        order = V.integer("order", order, minimum=0, maximum=chain.rho)
        return tuple(chain.derivatives[: order + 1])

    def normal_form(self) -> NormalForm:
        """The normal form: rho, ``sigma = y^(rho)``, ``a``, ``b``, coordinates, zero dynamics.

        Returns
        -------
        NormalForm

        Examples
        --------
        >>> import fl_design as fl
        >>> nf = fl.plants.trms_yaw().normal_form()
        >>> nf.rho, nf.minimum_phase
        (2, True)
        """
        from ._normal_form import NormalForm

        return self._derived("nf", lambda: derive_normal_form(self), NormalForm)

    @cached_property
    def _fh(self) -> tuple:
        return self._store.get("fh", self._translate_fh, tuple)

    def _translate_fh(self) -> tuple:
        args = [list(self._states), [self._input]]
        f = to_casadi(self._rhs, args, "f", subs=self._params_map, input_names=["x", "u"],
                      output_name="xdot")
        h = to_casadi(self._output, [list(self._states)], "h", subs=self._params_map,
                      input_names=["x"], output_name="y")
        return f, h

    def linearization(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Jacobians ``(A, B, C, D)`` at the operating point ``(x_op, u_eq)``.

        Returns
        -------
        A : numpy.ndarray, shape (n, n)
        B : numpy.ndarray, shape (n, 1)
        C : numpy.ndarray, shape (1, n)
        D : numpy.ndarray, shape (1, 1)
            Always zero (the output does not depend on the input).

        Examples
        --------
        >>> import fl_design as fl
        >>> A, B, C, D = fl.plants.pendulum().linearization()
        >>> A.round(3).tolist(), B.ravel().tolist()
        ([[0.0, 1.0], [-9.81, -0.5]], [0.0, 1.0])
        """
        import casadi as ca

        f, h = self._fh
        x, u = ca.SX.sym("x", self.n), ca.SX.sym("u")
        jac = ca.Function("lin", [x, u], [ca.jacobian(f(x, u), x), ca.jacobian(f(x, u), u),
                                          ca.jacobian(h(x), x)])
        A, B, C = (np.array(m.full(), dtype=float) for m in jac(self._x_op, self._u_eq))
        return A, B.reshape(self.n, 1), C.reshape(1, self.n), np.zeros((1, 1))

    def casadi(self) -> PlantFunctions:
        """CasADi SX functions ``f, h, sigma, b`` with numeric parameters (cached).

        Returns
        -------
        PlantFunctions

        Raises
        ------
        RelativeDegreeError
            If the relative degree is not defined (``sigma`` and ``b`` need it).

        Examples
        --------
        >>> import fl_design as fl
        >>> fns = fl.plants.trms_yaw().casadi()
        >>> fns.f
        Function(f:(x[2],u)->(xdot[2]) SXFunction)
        """
        def translate():
            chain = self._lie_chain()
            args = [list(self._states), [self._input]]
            kw = {"subs": self._params_map, "input_names": ["x", "u"]}
            sigma = to_casadi(chain.derivatives[chain.rho], args, "sigma", output_name="sigma", **kw)
            return sigma, to_casadi(chain.b, args, "b", output_name="b", **kw)

        if "casadi" not in self._cache:
            sigma, b = self._derived("sigma_b", translate, tuple)
            f, h = self._fh
            self._cache["casadi"] = PlantFunctions(f=f, h=h, sigma=sigma, b=b)
        return self._cache["casadi"]

    def _coordinates_function(self, order: int):
        """``fl_coords(x) -> [y, y', ..., y^(order-1)]`` as a CasADi function (cached on disk).

        The normal-form coordinates when ``order`` is the relative degree (the compiled loop's
        ``coordinates``); read from the cache without SymPy.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.plants.pendulum()._coordinates_function(2)([0.1, 0.2]).full().ravel().tolist()
        [0.1, 0.2]
        """
        def translate():
            coords = list(self.output_derivatives(order - 1))
            return to_casadi(coords, [list(self._states)], "fl_coords", subs=self._params_map,
                             input_names=["x"], output_name="coords")

        order = V.integer("order", order, minimum=1)
        import casadi as ca

        return self._derived(f"coords{order}", translate, ca.Function)

    def _zero_dynamics(self) -> tuple[bool, np.ndarray]:
        """``(minimum_phase, zero-dynamics eigenvalues)`` of :meth:`normal_form` (cached on
        disk: read without SymPy).

        Examples
        --------
        >>> import fl_design as fl
        >>> ok, eig = fl.plants.cart_pendulum(inverted=True)._zero_dynamics()
        >>> ok, eig.real.round(2).tolist()
        (False, [-7.46, 3.29])
        """
        def derive() -> tuple:
            nf = self.normal_form()
            return bool(nf.minimum_phase), np.asarray(nf.zero_dynamics_eigenvalues)

        return self._derived("zero_dynamics", derive, tuple)

    def b_bounds(self, *, allow_sign_change: bool = False) -> tuple[float, float]:
        """Bounds ``(b_min, b_max)`` of ``b = d y^(rho)/du`` over ``region x input_range``.

        Method: ``b`` is evaluated (NumPy) on a dense tensor grid over the box of the variables
        it actually depends on (at most ~2e5 points: 2001 per axis in 1-D, 447 in 2-D, 58 in 3-D;
        each axis also contains 0 and the operating point when inside; beyond 7 variables a
        scrambled Sobol sample of 2^16 points), then the 4 best grid points of each extreme are
        refined by bounded L-BFGS-B. A constant ``b`` is returned exactly; extremes on the box's
        faces, edges, corners or at 0 (kinks of ``|x|``) are found exactly.

        Parameters
        ----------
        allow_sign_change : bool, optional
            The method needs a known sign of b: by default a range containing 0 raises
            RelativeDegreeError; True returns the bounds anyway.

        Returns
        -------
        (float, float)

        Raises
        ------
        ParameterError
            ``b`` depends on a state without a range in ``region`` (named) or on the input and
            ``input_range`` is missing.
        RelativeDegreeError
            ``b`` changes sign or vanishes on the region (unless ``allow_sign_change``).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.plants.trms_yaw().b_bounds()
        (3.6..., 6.8...)
        """
        flag = bool(allow_sign_change)
        return self._derived(f"bounds{int(flag)}", lambda: b_bounds(self, allow_sign_change=flag),
                             tuple)

    def jacobian_bounds(self, *, region=None, margin: float = 0.05,
                        points: int = 200_000) -> tuple[tuple[float, float], ...]:
        """Bounds of ``d sigma/d xi_i`` (normal-form coordinates, ``u = u_eq``) over the region.

        The ``a_jacobian_bounds`` of :func:`fl_design.certify_eps`; computed by
        :func:`fl_design.symbolic._jacobian.jacobian_bounds` (dense grid, widened by ``margin``).

        Parameters
        ----------
        region : dict, optional
            ``{state: (lo, hi)}`` overriding the plant's region (e.g. a smaller one).
        margin : float, optional
            Relative widening of each range (default 0.05).
        points : int, optional
            Grid size (default 2e5).

        Returns
        -------
        tuple of (float, float)

        Raises
        ------
        RelativeDegreeError
            The plant has internal dynamics (``rho < n``).
        ParameterError
            A state has no range.

        Examples
        --------
        >>> import fl_design as fl
        >>> b = fl.plants.pendulum().jacobian_bounds(region={"theta": (-0.5, 0.5)}, margin=0)
        >>> [round(v, 2) for v in b[0]]
        [-9.81, -8.61]
        """
        from ._jacobian import jacobian_bounds

        return jacobian_bounds(self, region=region, margin=margin, points=points)



__all__ = ["Derivations"]
