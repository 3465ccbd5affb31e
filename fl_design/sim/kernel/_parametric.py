"""The closed loop with plant parameters as run-time inputs (a family of plants, one kernel).

:class:`~fl_design.sim.ClosedLoop` with ``uncertain=("c", "b")`` builds its accumulating step
from :func:`parametric_loop`: the plant's functions take the parameters as an input ``theta``
(:func:`parametric_plant`, translated from SymPy once per plant and set of names), and the
plant step integrates the augmented state ``[x; theta]`` with ``theta' = 0`` (RK4 carries
``theta`` exactly: ``theta + h * 0``). The step keeps the names the lanes emitter expects
(``fl_rk4``, a fold of ``fl_rk4_step``), so the lanes kernel unrolls it as the plant's own.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim import ClosedLoop
>>> loop = ClosedLoop(fl.plants.pendulum(), fl.presets.pendulum_design(), substeps=1,
...                   uncertain=("c", "b"))
>>> loop.uncertain_functions["control"].name_in()
['x', 's', 'r', 'w', 'q', 'p', 'theta']
"""

from __future__ import annotations

import functools

import casadi as ca

from ...errors import ParameterError


def parametric_loop(loop) -> dict:
    """The functions of ``loop`` (a ClosedLoop with ``uncertain``) with ``theta`` an input.

    :func:`parametric_plant`'s ``f h sigma b coords``, then ``control(x, s, r, w, q, p,
    theta)`` (as :attr:`ClosedLoop.control`) and ``plant_step([x; theta], u) -> [x_next;
    theta]`` (``substeps`` RK4 steps of the augmented state).

    Parameters
    ----------
    loop : ClosedLoop
        The loop (plant, design, substeps, uncertain names).

    Returns
    -------
    dict

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim import ClosedLoop
    >>> from fl_design.sim.kernel._parametric import parametric_loop
    >>> loop = ClosedLoop(fl.plants.pendulum(), fl.presets.pendulum_design(), substeps=2,
    ...                   uncertain=("b",))
    >>> parametric_loop(loop)["plant_step"]([0.1, 0.0, 2.0], 1.0).shape  # [x; theta]
    (3, 1)
    """
    fns = parametric_plant(loop.plant, loop.uncertain, loop.rho)
    f, h, sigma, coords = fns["f"], fns["h"], fns["sigma"], fns["coords"]
    n, nt = loop.n, len(loop.uncertain)
    # one RK4 step of the augmented state
    xa, u = ca.SX.sym("x", n + nt), ca.SX.sym("u")
    hstep = loop.T / loop.substeps
    th = xa[n:]

    def fa(z):
        return ca.vertcat(f(z[:n], u, th), ca.SX.zeros(nt))

    k1 = fa(xa)
    k2 = fa(xa + (hstep / 2) * k1)
    k3 = fa(xa + (hstep / 2) * k2)
    k4 = fa(xa + hstep * k3)
    x_next = xa[:n] + (hstep / 6) * (k1 + 2 * k2 + 2 * k3 + k4)[:n]
    rk4_step = ca.Function("fl_rk4_step", [xa, u], [ca.vertcat(x_next, th)], ["x", "u"],
                           ["x_next"])
    if loop.substeps == 1:
        step = ca.Function("fl_rk4", [xa, u], [rk4_step(xa, u)], ["x", "u"], ["x_next"])
    else:
        X, U = ca.MX.sym("x", n + nt), ca.MX.sym("u")
        step = ca.Function("fl_rk4", [X, U],
                           [rk4_step.fold(loop.substeps)(X, ca.repmat(U, 1, loop.substeps))],
                           ["x", "u"], ["x_next"], {"never_inline": True})
    x, s = ca.SX.sym("x", n), ca.SX.sym("s", loop.m)
    r, w, q, p = ca.SX.sym("r"), ca.SX.sym("w"), ca.SX.sym("q"), ca.SX.sym("p", loop.n_p)
    theta = ca.SX.sym("theta", nt)
    y = h(x, theta)
    q_safe = ca.if_else(q > 0, q, 1.0)
    ym = ca.if_else(q > 0, q_safe * ca.floor((y + w) / q_safe + 0.5), y + w)
    s_next, uc, xhat = loop.design.parametric_step(s, ym, r, p)
    control = ca.Function(
        "fl_control", [x, s, r, w, q, p, theta],
        [s_next, uc, y, ym, xhat, sigma(x, uc, theta), ca.vec(coords(x, theta))],
        ["x", "s", "r", "w", "q", "p", "theta"],
        ["s_next", "u", "y", "ym", "xhat", "sigma", "coords"])
    return {**fns, "control": control, "plant_step": step}


@functools.lru_cache(maxsize=16)
def parametric_plant(plant, names: tuple, rho: int) -> dict:
    """The plant's functions with the parameters ``names`` as an input ``theta`` (cached).

    ``f(x, u, theta)``, ``h(x, theta)``, ``sigma(x, u, theta)`` (``y^(rho)``), ``coords(x,
    theta)`` (``y .. y^(rho-1)``: the normal-form coordinates when ``rho`` is the plant's) and
    ``b(x, u, theta)`` (None when ``rho`` is not the plant's relative degree).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim.kernel._parametric import parametric_plant
    >>> fns = parametric_plant(fl.plants.pendulum(), ("b",), 2)
    >>> float(fns["b"]([0.0, 0.0], 0.0, 2.5))
    2.5
    """
    from ...symbolic._bridge import to_casadi  # SymPy: never in a worker that runs a kernel

    by_name = {sym.name: sym for sym in plant.params}
    theta = [by_name[name] for name in names]
    kw = {"subs": {k: v for k, v in plant.params.items() if k.name not in names}}
    states, inp = list(plant.states), plant.input
    own = plant.relative_degree() == rho
    xut, xt = [states, [inp], theta], [states, theta]
    return {
        "f": to_casadi(plant.rhs, xut, "f", input_names=["x", "u", "theta"],
                       output_name="xdot", **kw),
        "h": to_casadi(plant.output, xt, "h", input_names=["x", "theta"], output_name="y",
                       **kw),
        "sigma": to_casadi(plant.output_derivatives(rho)[-1], xut, "sigma",
                           input_names=["x", "u", "theta"], output_name="sigma", **kw),
        "b": to_casadi(plant.normal_form().b, xut, "b", input_names=["x", "u", "theta"],
                       output_name="b", **kw) if own else None,
        "coords": to_casadi(list(plant.normal_form().coordinates) if own
                            else list(plant.output_derivatives(rho - 1)), xt, "fl_coords",
                            input_names=["x", "theta"], output_name="coords", **kw),
    }


def uncertain_names(plant, names) -> tuple:
    """``names`` checked: a tuple of distinct parameter names of ``plant``.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim.kernel._parametric import uncertain_names
    >>> uncertain_names(fl.plants.pendulum(), ["c", "b"])
    ('c', 'b')
    """
    if isinstance(names, str) or not isinstance(names, (tuple, list)):
        raise ParameterError(f"uncertain must be a tuple of parameter names, got {names!r}")
    known = sorted(sym.name for sym in plant.params)
    for name in names:
        if name not in known:
            raise ParameterError(f"{name!r} is not a parameter of plant {plant.name!r}; its "
                                 f"parameters are {known}")
    if len(set(names)) != len(names):
        raise ParameterError(f"uncertain parameters repeat a name: {list(names)}")
    return tuple(names)


__all__ = ["parametric_loop", "parametric_plant", "uncertain_names"]
