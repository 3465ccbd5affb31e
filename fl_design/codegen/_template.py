"""Filling the C template files: ``@NAME@`` placeholders and the design's named constants.

Examples
--------
>>> from fl_design.codegen._template import render
>>> render("float @PREFIX@_step(void);", {"PREFIX": "fl"})
'float fl_step(void);'
"""

from __future__ import annotations

import re

import casadi as ca
import numpy as np

from ..design import EHGO, Design, LeastSquaresEstimator
from ..errors import ComputationError
from ._guard import PARAM_CHECK_PERIOD, design_hash, guard_settings


def render(text: str, subs: dict[str, str]) -> str:
    """Replace every ``@KEY@`` of ``subs`` in ``text``; a placeholder left over is an error.

    Parameters
    ----------
    text : str
        Template text.
    subs : dict
        ``{KEY: value}``.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.codegen._template import render
    >>> render("@A@ and $@", {"A": "x"})
    'x and $@'
    """
    for key, value in subs.items():
        text = text.replace(f"@{key}@", value)
    left = re.findall(r"@[A-Z][A-Z0-9_]*@", text)
    if left:
        raise ComputationError(f"template placeholders without a value: {sorted(set(left))}")
    return text


def c_literal(x: float, precision: str) -> str:
    """A C floating literal of ``x`` (``f``-suffixed in single precision).

    Parameters
    ----------
    x : float
        Finite value.
    precision : str
        ``"double"`` or ``"float"``.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.codegen._template import c_literal
    >>> c_literal(1e-3, "float"), c_literal(-2.0, "double")
    ('0.001f', '-2.0')
    """
    text = repr(float(x))
    return text + "f" if precision == "float" else text


def _fixed_constants(design: Design, precision: str, P: str) -> list[str]:
    lit = lambda x: c_literal(x, precision)
    est, rows = design.estimator, []
    if isinstance(est, EHGO):
        rows += [(f"{P}_EPS", lit(est.eps), "EHGO time constant eps (s)")]
        rows += [(f"{P}_ALPHA{i + 1}", lit(a), f"EHGO coefficient alpha_{i + 1}")
                 for i, a in enumerate(est.alphas)]
    elif isinstance(est, LeastSquaresEstimator):
        rows += [(f"{P}_WINDOW", str(est.window), "least-squares window (samples)"),
                 (f"{P}_FIT_DEGREE", str(est.fit_degree), "least-squares polynomial degree")]
    return [f"#define {name:<17} {value:<8} /* {what} */" for name, value, what in rows]


def _parameter_text(design: Design, precision: str, P: str) -> dict[str, str]:
    """Members, defaults and setter checks of the parameter block (``_graph.parameter_fields``)."""
    from ._graph import U_OPEN, parameter_fields

    lit = lambda x: c_literal(x, precision)
    real, rho = precision, design.rho
    fields = {f.name: f for f in parameter_fields(design)}
    clamped = [i for i, lim in enumerate(design.controller.estimate_ranges) if lim is not None]
    members = [f"  {real} gamma;        /* {fields['gamma'].what} */",
               f"  {real} k[{rho}];         /* gains k_1 .. k_rho of v */",
               f"  {real} ki;           /* integral gain k_I (>= 0) */",
               f"  {real} u_min;        /* input limits (u_min < u_max) */",
               f"  {real} u_max;"]
    if clamped:
        used = ", ".join(str(i) for i in clamped)
        members += [(f"  {real} xhat_min[{rho}];  /* clamps of the estimates; entries {used} "
                     "are used */"), f"  {real} xhat_max[{rho}];"]
    members.append("  int antiwindup;      /* 1: hold z while u is on a limit and z pushes it "
                   "further (conditional integration); 0: the design's law */")
    defaults = [f"  p->{name} = {lit(f.value)};" for name, f in fields.items()
                if name != "antiwindup"]
    if clamped:
        defaults += [f"  p->xhat_{side}[{i}] = {lit(sign * U_OPEN)};  /* not clamped */"
                     for i in range(rho) if i not in clamped
                     for side, sign in (("min", -1), ("max", 1))]
    defaults.append(f"  p->antiwindup = {int(design.controller.antiwindup)};")
    finite = [f"!{{PFX}}_finite(p->{name})" for name in fields if name != "antiwindup"]
    checks = ["  if (" + (" ||\n      ".join(finite)) + ") {",
              f"    return {P}_BAD_NONFINITE;", "  }"]
    sign = ">" if design.controller.gamma > 0 else "<"
    checks += [f"  if (!(p->gamma {sign} ({real}) 0)) {{", f"    return {P}_BAD_GAMMA;", "  }",
               f"  if (p->ki < ({real}) 0) {{", f"    return {P}_BAD_GAINS;", "  }",
               "  if (!(p->u_min < p->u_max)) {", f"    return {P}_BAD_U_LIMITS;", "  }"]
    for i in clamped:
        checks += [f"  if (p->xhat_min[{i}] > p->xhat_max[{i}]) {{",
                   f"    return {P}_BAD_XHAT_LIMITS;", "  }"]
    checks += ["  if ((p->antiwindup != 0) && (p->antiwindup != 1)) {",
               f"    return {P}_BAD_SWITCH;", "  }"]
    reals = ["gamma", *(f"k[{i}]" for i in range(rho)), "ki", "u_min", "u_max"]
    if clamped:
        reals += [f"xhat_{side}[{i}]" for side in ("min", "max") for i in range(rho)]
    reals += ["y_min", "y_max", "dy_max", "u_safe"]
    summed = [f"  h = {{PFX}}_mix_real(h, p->{name});" for name in reals]
    summed += ["  h = {PFX}_mix(h, (uint32_t) p->antiwindup);",
               "  h = {PFX}_mix(h, p->lost_after);", "  h = {PFX}_mix(h, p->frozen_after);"]
    # member by member: a struct assignment of this size is a memcpy call on some targets
    copied = [f"  s->p.{name} = p->{name};" for name in reals]
    copied += [f"  s->p.{name} = p->{name};" for name in ("antiwindup", "lost_after",
                                                          "frozen_after")]
    return {"PARAM_MEMBERS": "\n".join(members), "PARAM_DEFAULTS": "\n".join(defaults),
            "PARAM_CHECKS": "\n".join(checks), "PARAM_SUM": "\n".join(summed),
            "PARAM_COPY": "\n".join(copied)}


def _excitation(design, g, lit) -> dict[str, str]:
    """Suggested excitation: 2 % of the output's plausible span (at most 0.1 without a plant),
    held for the closed loop's slowest time constant (the roots of the gains' polynomial)."""
    hold = max(1, round(design.controller.time_constant / design.T))
    span = g.y_max - g.y_min
    amp = 0.02 * span if span < 1e6 else 0.1
    why = ("2 % of the plausibility range" if span < 1e6 else "0.1 (no plant: a guess)")
    return {"EXCITE_AMPLITUDE": lit(amp), "EXCITE_HOLD": str(hold), "EXCITE_WHY": why}


def _units(design, plant) -> str:
    rho = design.rho
    # the names from the plant's cached header (no SymPy for a cached library plant)
    names = getattr(plant, "_names", None) if plant is not None else None
    y_text, u_text = (names[2], names[1]) if names else ("y", "u")
    out = "the plant's output" if plant is None else f"the output {y_text}"
    inp = "input" if plant is None else f"input {u_text}"
    rows = [f"/* y, r, y_min, y_max, dy_max, xhat_1: units of {out} (those of the model the",
            " * design was made for); u, u_min, u_max, u_safe: units of the " + inp + ";",
            f" * xhat_i: y units / s^(i-1); sigmahat: y units / s^{rho}; T, eps: s;",
            (f" * k_i: 1 / s^({rho} - i + 1); k_I: 1 / s^{rho + 1}; gamma: u units per "
            f"(y units / s^{rho}). */")]
    return "\n".join(rows)


def tail_function(tail: dict, design: Design, precision: str, prefix: str) -> tuple[str, str]:
    """The saturated samples' continuation and its call from ``<prefix>_run_fast``.

    ``(function, call)``: ``<prefix>_saturated`` takes the common path's results and the
    values the saturation's branches read (``tail``, from :func:`core_source`) and finishes
    the step; without a keyed saturation, ``<prefix>_run_saturated`` runs the arithmetic again.
    """
    P, real = prefix.upper(), precision
    if not tail:
        function = (f"/* the step's arithmetic when u reaches a limit (or is not finite): "
                    f"{prefix}_core's saturated\n * branches, out of line */\n"
                    f"{P}_COLD static {real} {prefix}_run_saturated({prefix}_state_t *s, "
                    f"{real} yd, {real} r) {{\n  return {prefix}_run(s, yd, r);\n}}")
        return function, f"    return {prefix}_run_saturated(s, yd, r);"
    n, m, nt = design.state_size, design.rho + 1, len(tail["frontier"])
    params = ([f"{real} n{i}" for i in range(n)] + [f"{real} h{i}" for i in range(m)]
              + [f"{real} t{i}" for i in range(nt)] + [f"{real} r_abs"])
    body = "\n".join(line for line in tail["body"].splitlines()
                     if not line.lstrip().startswith("*u ="))
    used = {v: re.search(pattern, body) is not None for v, pattern in
            (("x", r"\bx\["), ("p", r"\bp->"), ("y", r"\by\b"), ("r", r"\br\b"))}
    # y and r (deviations) passed only when read: each float argument takes a register
    lead = [f"{real} y"] * used["y"] + [f"{real} r"] * used["r"]
    lead_args = ["yd"] * used["y"] + ["r - s->y_c"] * used["r"]
    unused = [v for v in ("x", "p") if not used[v]]
    comment = (f"/* u at a limit (or not finite) on the common path: the saturation's branches "
               f"and what\n * follows from them (the conditional integration), from the values "
               f"{prefix}_core_fast computed\n * (its results n, h, the values t its branches "
               f"read, its sum c), then {prefix}_finish */")
    text = [comment,
            f"{P}_COLD static {real} {prefix}_saturated({prefix}_state_t *s, "
            + "".join(f"{a}, " for a in lead) + f"{real} c,",
            "    " + ", ".join(params) + ") {",
            "  const " + real + " *x = s->x;",
            f"  const {prefix}_params_t *p = &s->p;",
            f"  {real} x_next[{P}_STATE_SIZE] = {{{', '.join(f'n{i}' for i in range(n))}}};",
            f"  {real} xhat[{P}_RHO + 1] = {{{', '.join(f'h{i}' for i in range(m))}}};",
            *(f"  (void) {v};" for v in unused), body,
            f"  return {prefix}_finish(s, r_abs, x_next, xhat, a_sum);", "}"]
    args = ([f"x_next[{i}]" for i in range(n)] + [f"xhat[{i}]" for i in range(m)]
            + [f"tail[{i}]" for i in range(nt)])
    call = (f"    return {prefix}_saturated(s, " + "".join(f"{a}, " for a in lead_args)
            + "chk, " + ", ".join(args) + ", r);")
    return "\n".join(text), call


def _fast_keys(prefix: str, precision: str) -> dict:
    """The common path's test of u within its limits (:func:`._emit.c_body`'s ``keys``): the
    order keys in float; in double the float compares with the derived limits (the keys'
    transfers to integer registers cost 1.6 ns of 9.4 on a 64-bit host), u before its limits
    then staying in the finiteness sum."""
    keys = {"bounds": ("p->u_min", "p->u_max"), "fn": f"{prefix}_key", "lo1": "ukey[0]",
            "span": "ukey[1]", "bail": "*sat"}
    if precision == "double":
        keys.update(test="!((ulim[0] < {v}) && ({v} < ulim[1]))", proves=False)
    return keys


def core_source(design: Design, precision: str, prefix: str, *,
                fast: bool = False, tail: dict | None = None) -> tuple[str, int]:
    """The body of ``<prefix>_step_core`` and the number of instructions of its graph.

    ``tail`` (with ``fast``): filled with the saturated samples' continuation
    (:func:`tail_function`). ``fast``: the body of ``<prefix>_core_fast``, the common path's: in float, ``u`` within
    its limits told on order keys (``*sat`` = 0), the saturated branches left to
    ``<prefix>_core``; in double the same with float compares (:func:`_fast_keys`).

    Parameters
    ----------
    design : Design
        The design generated.
    precision : str
        ``"double"`` or ``"float"``.
    prefix : str
        C prefix.

    Returns
    -------
    tuple of (str, int)

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._template import core_source
    >>> body, n = core_source(presets.paper_design(), "float", "fl")
    >>> "fmax" in body, n > 0
    (False, True)
    """
    from ._emit import c_body
    from ._graph import parameter_fields, parametric_core

    f = parametric_core(design, f"{prefix}_step_core")
    names = [f"p->{fl.name}" for fl in parameter_fields(design)]
    n = design.state_size
    body = c_body(f, [[f"x[{i}]" for i in range(n)], ["y"], ["r"], names],
                  [[f"x_next[{i}]" for i in range(n)], ["*u"],
                   [f"xhat[{i}]" for i in range(design.rho + 1)]], precision,
                  switches={"p->antiwindup"},
                  rare=f"{prefix.upper()}_RARE", check="*chk", required=((0, 1, 2), (1,)),
                  keys={**_fast_keys(prefix, precision), "tail": tail} if fast else None)
    if fast and tail:
        body += "".join(f"\n  tail[{i}] = {a};" for i, a in enumerate(tail["frontier"]))
    unused = [v for v in ("x", "y", "r", "p") if not re.search(rf"\b{v}\b", body)]
    if fast and "*sat" not in body:  # no input saturation
        body += "\n  *sat = false;"
    unused += [v for v in ("ukey", "ulim", "tail") if fast and v not in body]
    body = "".join(f"  (void) {v};\n" for v in unused) + body
    return body, int(f.n_instructions())


def substitutions(design: Design, precision: str, prefix: str, guard=None,
                  plant=None) -> dict[str, str]:
    """Every placeholder value of the templates for ``design``.

    Parameters
    ----------
    design, precision, prefix
        As in :func:`core_source` (the design after :func:`~fl_design.codegen.step_design`).
    guard : GuardSettings, optional
        The checks' defaults (default :func:`~fl_design.codegen._guard.guard_settings`).
    plant : Plant, optional
        For the names in the header's units.

    Returns
    -------
    dict

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen._template import substitutions
    >>> substitutions(presets.paper_design(), "double", "fl")["STATE_SIZE"]
    '5'
    """
    import fl_design

    from ._graph import start_map

    P = prefix.upper()
    lay = design.state_layout
    lit = lambda x: c_literal(x, precision)
    c0, c1 = start_map(design)
    body, n_ins = core_source(design, precision, prefix)
    tail: dict = {}
    fast_body = core_source(design, precision, prefix, fast=True, tail=tail)[0]
    tail_text, tail_call = tail_function(tail, design, precision, prefix)
    from ._graph import parametric_core
    from ._opcount import operation_counts

    ops = operation_counts(parametric_core(design))
    size = 4 if precision == "float" else 8
    subs = {
        "PREFIX": prefix, "P": P, "REAL": precision, "PRECISION": precision,
        "VERSION": fl_design.__version__, "CASADI_VERSION": ca.__version__,
        "DESCRIPTION": " ".join(repr(design).split()),
        "FIXED_CONSTANTS": "\n".join(_fixed_constants(design, precision, P)),
        "T_LITERAL": lit(design.T), "RHO": str(design.rho),
        "STATE_SIZE": str(design.state_size), "ESTIMATOR_SIZE": str(lay["estimator"].stop),
        "U_INDEX": str(lay["u"].start), "Z_INDEX": str(lay["z"].start),
        "INITIAL_STATE": ", ".join(lit(v) for v in design.initial_state()),
        "START0": ", ".join(lit(v) for v in c0), "START1": ", ".join(lit(v) for v in c1),
        "UINT": "uint32_t" if precision == "float" else "uint64_t",
        "SIGN_SHIFT": "31" if precision == "float" else "63",
        "EXP_MASK": "0x7F800000u" if precision == "float" else "UINT64_C(0x7FF0000000000000)",
        "ARM_FP_BIT": "4" if precision == "float" else "8",  # ACLE __ARM_FP: single, double
        "BODY": body, "BODY_FAST": fast_body, "TAIL_FUNCTION": tail_text, "TAIL_CALL": tail_call,
        "TAIL_SIZE": str(max(1, len(tail.get("frontier", ())))),
        "N_INSTRUCTIONS": str(n_ins), "FLOPS": str(sum(ops.values())),
        "FLOP_DETAIL": ", ".join(f"{v} {k}" for k, v in ops.items() if v),
        "COMMIT": "\n".join([f"  s->x[{i}] = {prefix}_flush(x_next[{i}]);"
                             for i in range(design.state_size)]
                            + [f"  s->xhat[{i}] = xhat[{i}];"
                               for i in range(design.rho + 1)]),
        "STATE_BYTES": str(size * design.state_size),
        "REAL_MAX": lit(float(np.finfo(np.float32 if precision == "float" else np.float64).max)),
        "RATE": (f"{1e-3 / design.T:g} kHz" if design.T <= 1e-3 else f"{1.0 / design.T:g} Hz"),
        "T": f"{design.T:g}",
    }
    params = _parameter_text(design, precision, P)
    for key in ("PARAM_CHECKS", "PARAM_SUM"):
        params[key] = params[key].replace("{PFX}", prefix)
    subs.update(params)
    g = guard_settings(design) if guard is None else guard
    digest = design_hash(design, precision)
    subs.update({
        "Y_MIN": lit(g.y_min), "Y_MAX": lit(g.y_max), "DY_MAX": lit(g.dy_max),
        "U_SAFE": lit(g.u_safe), "LOST_AFTER": str(int(g.lost_after)),
        "FROZEN_AFTER": str(int(g.frozen_after)), "U_OP_LITERAL": lit(g.u_op),
        "PARAM_CHECK_PERIOD": str(PARAM_CHECK_PERIOD), "GUARD_SOURCE": g.source,
        "DESIGN_HASH": digest, "DESIGN_HASH_U32": "0x" + digest[:8].upper(),
        "UNITS": _units(design, plant),
        "DEVIATION": "1" if precision == "float" else "0",
        **_excitation(design, g, lit),
        "MIX_REAL": ("  return " + prefix + "_mix(h, " + prefix + "_bits(v));" if precision == "float"
                     else "  const uint64_t b = " + prefix + "_bits(v);\n  return " + prefix
                     + "_mix(" + prefix + "_mix(h, (uint32_t) (b & 0xFFFFFFFFu)), (uint32_t) (b >> 32));"),
    })
    return subs


__all__ = ["c_literal", "core_source", "render", "substitutions"]
