"""The files of a Q31 package: template values, the test vectors (bit-exact), the error.

Examples
--------
>>> from fl_design.codegen._guard import guard_settings
>>> from fl_design.codegen._q31_files import q31_range
>>> q31_range(guard_settings(fl.presets.paper_design()))[:2]
(-10.0, 10.0)
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ._q31 import q31_program
from ._q31_code import SAT_SHL, c_body_q31, emulate_q31, start_c, start_state
from ._vectors import hold_rejected, vector_file, vector_record

#: the recursion's measured error may exceed the matrix form's by this factor at most (it
#: has fewer products; past that the package keeps the matrix: precision before cost)
ERROR_MARGIN = 2.0

#: the range of ``y`` a Q31 build assumes when no plant gives one
Q31_DEFAULT_RANGE = (-10.0, 10.0)


def q31_range(guard) -> tuple[float, float, str]:
    """``(lo, hi, why)``: the range of ``y`` and ``r`` the Q31 scalings are analysed over.

    Parameters
    ----------
    guard : GuardSettings
        The checks' defaults (the plant region's output range, when a plant was given).

    Returns
    -------
    tuple

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.codegen._guard import guard_settings
    >>> from fl_design.codegen._q31_files import q31_range
    >>> lo, hi, _ = q31_range(guard_settings(fl.presets.maglev_design(), fl.plants.maglev()))
    >>> lo < 0.004 < 0.008 < hi
    True
    """
    if guard.y_max - guard.y_min < 1e6:
        return float(guard.y_min), float(guard.y_max), guard.source
    lo, hi = Q31_DEFAULT_RANGE
    return lo, hi, (f"|y| <= {hi:g}, assumed: no plant was given to generate_c (pass plant= "
                    "for the region's range)")


def _q(v: float, f: int) -> int:
    return int(max(-(2**31), min(2**31 - 1, round(v * 2.0**f))))


def _lit(v: int) -> str:
    return f"INT32_C({v})" if v >= 0 else f"(-INT32_C({-v}))" if v > -(2**31) else "INT32_MIN"


def q31_base(design, prefix: str, guard) -> dict:
    """The values every Q31 template shares (names, sizes, version, hash).

    Parameters
    ----------
    design : Design
        The generated design.
    prefix : str
        C prefix.
    guard : GuardSettings
        The checks' defaults.

    Returns
    -------
    dict
        Template name -> value (``PREFIX``, sizes, version, design hash, precision).

    Examples
    --------
    >>> from fl_design.codegen._guard import guard_settings
    >>> from fl_design.codegen._q31_files import q31_base
    >>> d = fl.presets.paper_design()
    >>> q31_base(d, "fl", guard_settings(d))["PRECISION"]
    'q31'
    """
    import casadi as ca

    import fl_design

    from ._guard import design_hash

    digest = design_hash(design, "q31")
    lay = design.state_layout
    return {"PREFIX": prefix, "P": prefix.upper(), "VERSION": fl_design.__version__,
            "CASADI_VERSION": ca.__version__, "DESCRIPTION": " ".join(repr(design).split()),
            "PRECISION": "q31", "RHO": str(design.rho), "STATE_SIZE": str(design.state_size),
            "ESTIMATOR_SIZE": str(lay["estimator"].stop), "U_INDEX": str(lay["u"].start),
            "Z_INDEX": str(lay["z"].start), "DESIGN_HASH": digest,
            "DESIGN_HASH_U32": "0x" + digest[:8].upper(), "LOST_AFTER": str(guard.lost_after)}


def q31_substitutions(design, prefix: str, guard, base: dict):
    """The template values of ``step_q31.*.in`` (on top of ``base``) and the program.

    Parameters
    ----------
    design : Design
        The generated design (delta realization).
    prefix : str
        C prefix.
    guard : GuardSettings
        The checks' defaults.
    base : dict
        The common values (prefix, version, hash, sizes...).

    Returns
    -------
    tuple of (dict, Q31Program, tuple)
        The template values, the integer program and the input range it was scaled for.

    Examples
    --------
    >>> from fl_design.codegen._guard import guard_settings
    >>> from fl_design.codegen._q31_files import q31_substitutions
    >>> d = fl.codegen.step_design(fl.presets.paper_design(), "q31")
    >>> subs, prog, rng = q31_substitutions(d, "fl", guard_settings(d), {})
    >>> subs["F_Y"], rng[:2]
    ('26', (-10.0, 10.0))
    """
    lo, hi, why = q31_range(guard)
    prog = q31_program(design, (lo, hi))
    if prog.realization == "recursion":  # fewer products, kept unless it loses precision
        matrix = q31_program(design, (lo, hi), update="matrix")
        if q31_error(design, prog, guard) > ERROR_MARGIN * q31_error(design, matrix, guard):
            prog = matrix
    f_u = prog.f_state[-2]
    u_lo, u_hi = design.controller.u_range
    x0 = [_q(v, prog.f_state[i]) for i, v in enumerate(design.initial_state())]
    subs = dict(base)
    body = c_body_q31(prog).replace("{PFX}", prefix)
    subs.update({
        "BODY_Q31": body,
        "SAT_SHL": SAT_SHL.replace("{PFX}", prefix) if f"{prefix}_sat_shl(" in body else "",
        "START_Q31": start_c(prog).replace("{PFX}", prefix),
        "COMMIT_Q31": "\n".join(f"    s->x[{i}] = x_next[{i}];" for i in range(len(x0))),
        "F_Y": str(prog.f_y), "F_U": str(f_u),
        "Y_LO_Q": _lit(_q(lo, prog.f_y)), "Y_HI_Q": _lit(_q(hi, prog.f_y)),
        "Y_LO": f"{lo:.9g}", "Y_HI": f"{hi:.9g} ({why})",
        "U_MIN_Q": _lit(_q(u_lo, f_u)), "U_MAX_Q": _lit(_q(u_hi, f_u)),
        "U_OP_Q": _lit(_q(guard.u_op, f_u)), "U_OP": f"{guard.u_op:.9g}",
        "F_STATE": ", ".join(map(str, prog.f_state)),
        "INITIAL_STATE_Q": ", ".join(_lit(v) for v in x0),
        "T_US": str(max(1, round(design.T * 1e6))),
        "Z_BOX": f"{prog.state_box[-1][1]:.6g}",
        "Q31_REALIZATION": ("as its recursion (see Cost)" if prog.realization == "recursion"
                            else "as its matrix"),
    })
    return subs, prog, (lo, hi, why)


def q31_expected(design, prog, guard, n: int):
    """``(yq, rq, uq)``: the vector record in Q units and the Q31 step's inputs (bit-exact).

    Parameters
    ----------
    design : Design
        The generated design.
    prog : Q31Program
        Its program.
    guard : GuardSettings
        Gives the operating point's input.
    n : int
        Samples.

    Returns
    -------
    tuple of numpy.ndarray

    Examples
    --------
    >>> from fl_design.codegen._guard import guard_settings
    >>> from fl_design.codegen._q31 import q31_program
    >>> from fl_design.codegen._q31_files import q31_expected
    >>> d = fl.codegen.step_design(fl.presets.paper_design(), "q31")
    >>> y, r, u = q31_expected(d, q31_program(d, (-10.0, 10.0)), guard_settings(d), 50)
    >>> int(u[20]) == int(u[19])  # the out-of-range sample 10 is held... and 20 too
    True
    """
    y, r = vector_record(*prog.y_range, n)
    yq = np.array([_q(v, prog.f_y) for v in y], dtype=np.int64)
    rq = np.array([_q(v, prog.f_y) for v in r], dtype=np.int64)
    bad = [n // 5, (2 * n) // 5]
    yq[bad] = 2**31 - 1  # outside the range: rejected, u held
    f_u = prog.f_state[-2]
    u_lo, u_hi = design.controller.u_range
    u0 = min(max(_q(guard.u_op, f_u), _q(u_lo, f_u)), _q(u_hi, f_u))
    keep = np.ones(n, bool)
    keep[bad] = False
    u_kept, _ = emulate_q31(prog, yq[keep], rq[keep], start_state(prog, int(yq[0]), u0))
    return yq, rq, hold_rejected(np.asarray(u_kept, dtype=np.int64), keep, u0)


def q31_vector_text(design, prog, guard, digest: str, n: int = 1500) -> str:
    """The Q31 vector file: raw ``int32`` values, tolerance 0 (the program is bit-exact).

    Parameters
    ----------
    design, prog, guard, n
        As in :func:`q31_expected`.
    digest : str
        The design's hash.

    Returns
    -------
    str
        The file's text (comment lines, ``tol 0``, one ``y r u`` line of integers per sample).

    Examples
    --------
    >>> from fl_design.codegen._guard import guard_settings
    >>> from fl_design.codegen._q31 import q31_program
    >>> from fl_design.codegen._q31_files import q31_vector_text
    >>> d = fl.codegen.step_design(fl.presets.paper_design(), "q31")
    >>> q31_vector_text(d, q31_program(d, (-1.0, 1.0)), guard_settings(d), "x", 10).split(
    ...     "\\n")[3]
    'tol 0'
    """
    y, r, u = q31_expected(design, prog, guard, n)
    comments = [
        f"test vectors of the generated Q31 step; design hash {digest}",
        (f"y, r in Q{prog.f_y} (y * 2^{prog.f_y}), u in Q{prog.f_state[-2]}; start: "
         "PREFIX_start(first y, PREFIX_U_OP)"),
        "u_expected: the same integer program run in Python (bit-exact: tolerance 0)"]
    return vector_file(comments, 0, y, r, u)


def q31_error(design, prog, guard, n: int = 3000) -> float:
    """The Q31 step's ``max |u_q31 - u_double| / max |u_double|`` on the vector record.

    Parameters
    ----------
    design, prog, guard, n
        As in :func:`q31_expected`.

    Returns
    -------
    float
        The relative error (divided by at least one unit in the last place of ``u``).

    Examples
    --------
    >>> from fl_design.codegen._guard import guard_settings
    >>> from fl_design.codegen._q31 import q31_program
    >>> from fl_design.codegen._q31_files import q31_error
    >>> d = fl.codegen.step_design(fl.presets.paper_design(), "q31")
    >>> q31_error(d, q31_program(d, (-10.0, 10.0)), guard_settings(d), 500) < 1e-2
    True
    """
    from ._compare import reference_run

    yq, rq, uq = q31_expected(design, prog, guard, n)
    keep = yq != 2**31 - 1
    y, r = yq[keep] / 2.0**prog.f_y, rq[keep] / 2.0**prog.f_y
    f_u = prog.f_state[-2]
    u0 = min(max(guard.u_op, design.controller.u_range[0]), design.controller.u_range[1])
    u_ref = reference_run(design, y, r, state0=design.initial_state(y0=y[0], u0=u0))[0]
    u_q = uq[keep] / 2.0**f_u
    scale = max(float(np.max(np.abs(u_ref))), math.ldexp(1.0, -f_u))
    return float(np.max(np.abs(u_q - u_ref)) / scale)


#: bits a Q15 word has fewer than a Q31 word
Q15_SHORTER = 16


def _shorter_data(data, d: int):
    """A product by a constant's ``("mulc", c_q, s)`` with ``c_q`` ``d`` bits shorter (its
    shift too: the result keeps the fraction bits of the value's, ``d`` fewer); other data as
    it is."""
    if isinstance(data, tuple) and data[0] == "mulc":
        return ("mulc", round(data[1] / 2.0**d), data[2] - d)
    return data


def q15_program(prog):
    """The Q31 program with every value 16 bits shorter: ``int16_t`` words with the same one
    bit of headroom, constants rounded to them, products of two words in 32 bits. The integer
    model (:func:`~fl_design.codegen._q31_code.emulate_q31`) runs it as it runs the Q31 one.

    Parameters
    ----------
    prog : Q31Program
        The Q31 program.

    Returns
    -------
    Q31Program

    Examples
    --------
    >>> from fl_design.codegen._q31 import q31_program
    >>> from fl_design.codegen._q31_files import q15_program
    >>> p = q31_program(fl.presets.paper_design(), (-1.0, 1.0))
    >>> q15_program(p).f_y == p.f_y - 16
    True
    """
    from dataclasses import replace

    from ._q31 import _CMP

    logic = set(_CMP) | {ca.OP_NOT, ca.OP_AND, ca.OP_OR}
    d = Q15_SHORTER
    # truth values (comparisons, logic: F = 0) keep theirs; a constant's data is a float
    ops = tuple(op if (op[0] == "op" and not isinstance(op[4], float) and op[4] in logic)
                else (op[0], op[1], op[2], op[3] - d, _shorter_data(op[4], d))
                for op in prog.ops)
    shorter = lambda v: round(v / 2.0**d)
    return replace(prog, ops=ops, f_state=tuple(f - d for f in prog.f_state), f_y=prog.f_y - d,
                   start0=tuple(shorter(v) for v in prog.start0),
                   start1=tuple(shorter(v) for v in prog.start1), f_start1=prog.f_start1 - d)


__all__ = ["ERROR_MARGIN", "Q15_SHORTER", "Q31_DEFAULT_RANGE", "q15_program", "q31_base",
           "q31_error", "q31_expected", "q31_range", "q31_substitutions", "q31_vector_text"]
