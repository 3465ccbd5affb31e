"""Plain-text (and LaTeX) derivation report of a plant: the first thing a user reads.

Examples
--------
>>> from fl_design.app._report import derivation_report
>>> text = derivation_report(fl.plants.trms_yaw())
>>> "relative degree rho = 2" in text
True
"""

from __future__ import annotations

from ._text import paper_gamma_bound


def _fmt(expr, latex: bool) -> str:
    import sympy as sp  # here only: a run whose derivation is cached never imports SymPy

    return sp.latex(expr) if latex else sp.sstr(expr)


def derivation_report(plant, *, latex: bool = False) -> str:
    """Return the derivation report of ``plant`` as text.

    Parameters
    ----------
    plant : fl_design.Plant
        The plant to derive (any plant built with :meth:`fl_design.Plant.from_ode`).
    latex : bool, optional
        Also print the LaTeX form of ``a``, ``b`` and the approximate model ``F^a``.

    Returns
    -------
    str
        Relative degree, normal-form coordinates, ``a`` and ``b`` (``sigma = a + b u``), the
        numeric b-range over the plant's declared region and input range (when declared), the
        zero dynamics verdict and the residual orders of the sampled approximate model.

    Examples
    --------
    >>> from fl_design.app._report import derivation_report
    >>> print(derivation_report(fl.plants.pendulum()).splitlines()[0])
    Plant: pendulum
    """
    import sympy as sp

    from ..symbolic._discretization import taylor_discretization

    nf = plant.normal_form()
    lines = [f"Plant: {plant.name}",
             (f"  states: {', '.join(map(str, plant.states))};"
              f" input: {plant.input}; output y = {plant.output}"),
             f"  relative degree rho = {nf.rho} (n = {plant.n})",
             "  normal-form coordinates L_f^(i-1) h:"]
    lines += [f"    x{i + 1} = {_fmt(c, False)}" for i, c in enumerate(nf.coordinates)]
    lines += [f"  a(x) = {_fmt(nf.a, False)}", f"  b(x) = {_fmt(nf.b, False)}"]
    if latex:
        lines += [f"  LaTeX a: {_fmt(nf.a, True)}", f"  LaTeX b: {_fmt(nf.b, True)}"]
    if plant.region is not None and plant.input_range is not None:
        b_min, b_max = plant.b_bounds()
        lines.append(f"  b-range over the region: [{b_min:.6g}, {b_max:.6g}]"
                     f"  -> paper's {paper_gamma_bound((b_min, b_max))[1]}")
    if plant.n > nf.rho:
        eig = ", ".join(f"{z:.4g}" for z in nf.zero_dynamics_eigenvalues)
        verdict = "minimum phase" if nf.minimum_phase else "NOT minimum phase"
        lines.append(f"  zero dynamics (linearized) eigenvalues: {eig} -> {verdict}")
    else:
        lines.append("  no zero dynamics (n = rho): minimum phase trivially")
    disc = taylor_discretization(nf.rho, order=nf.rho + 1)
    lines.append("  sampled approximate extended model F^a (T = alpha*eps):")
    lines += ["    " + row for row in sp.pretty(disc.approx, use_unicode=False).splitlines()]
    if latex:
        lines.append(f"  LaTeX F^a: {_fmt(disc.approx, True)}")
    lines.append("  residual F^e - F^a per component (sigma_dot: time derivative of sigma):")
    lines += ["    " + row for row in disc.residual_order_table().splitlines()]
    return "\n".join(lines)
