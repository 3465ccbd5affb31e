"""C for W grid points at once, emitted from the SX instruction list of the accumulating step.

:func:`lanes_source` walks the instructions of ``fl_acc`` (and, when the plant step is a call
to ``fold(fl_rk4_step)``, those of the single RK4 step) and writes each one as a C statement
on one lane ``l`` of a ``#pragma omp simd`` loop over ``W`` lanes: the accumulators are stored
structure-of-arrays (``A[i * W + l]``, updated in place: an accumulator entry the step
only copies is not touched), every instruction result is a fresh local (the compiler
keeps them in vector registers), and math calls are vectorised by glibc's libmvec where it has
them. The RK4 substeps are a C loop around the single step, so the source does not grow with
their number. Nothing is written by hand: an operation the table below does not know raises
:class:`LanesUnsupported` and the caller keeps the scalar kernel.

Operations are printed as CasADi's code generator prints them (``casadi_sq(x) = x*x``,
``c ? a : 0``, ``fmin``/``fmax`` as glibc computes them on x86-64, ``casadi_sign``), and the
kernel is compiled without floating-point contraction, so a lane computes what the scalar
kernel and the interpreter compute (up to the last bits of libmvec's vector ``tanh``, ``sin``,
... against glibc's scalar ones).

Examples
--------
>>> import casadi as ca
>>> from fl_design.sim.kernel._emit import lanes_source
>>> x = ca.SX.sym("x", 2)
>>> f = ca.Function("fl_acc", [x, ca.SX.sym("d", 2)], [ca.vertcat(x[0] + x[1], ca.tanh(x[1]))])
>>> "tanh(" in lanes_source(f, {"k": 0, "div": 1, "N": 1}, width=4)
True
"""

from __future__ import annotations

import functools
import math
from importlib import resources

import casadi as ca

_BIN = {ca.OP_ADD: "({0}+{1})", ca.OP_SUB: "({0}-{1})", ca.OP_MUL: "({0}*{1})",
        ca.OP_DIV: "({0}/{1})", ca.OP_LT: "({0}<{1} ? 1.0 : 0.0)",
        ca.OP_LE: "({0}<={1} ? 1.0 : 0.0)", ca.OP_EQ: "({0}=={1} ? 1.0 : 0.0)",
        ca.OP_NE: "({0}!={1} ? 1.0 : 0.0)",
        ca.OP_AND: "(({0}!=0) & ({1}!=0) ? 1.0 : 0.0)",
        ca.OP_OR: "(({0}!=0) | ({1}!=0) ? 1.0 : 0.0)",
        ca.OP_IF_ELSE_ZERO: "({0}!=0 ? {1} : 0.0)",
        ca.OP_FMIN: "(({0}<{1} || {1}!={1}) ? {0} : {1})",
        ca.OP_FMAX: "(({0}>{1} || {1}!={1}) ? {0} : {1})",
        ca.OP_POW: "pow({0},{1})", ca.OP_CONSTPOW: "pow({0},{1})",
        ca.OP_ATAN2: "atan2({0},{1})", ca.OP_COPYSIGN: "copysign({0},{1})",
        ca.OP_FMOD: "fmod({0},{1})", ca.OP_HYPOT: "hypot({0},{1})"}
_UN = {ca.OP_NEG: "(-{0})", ca.OP_SQ: "({0}*{0})", ca.OP_TWICE: "(2.*{0})",
       ca.OP_INV: "(1./{0})", ca.OP_NOT: "({0}==0 ? 1.0 : 0.0)",
       ca.OP_SIGN: "({0}<0 ? -1.0 : ({0}>0 ? 1.0 : {0}))", ca.OP_ASSIGN: "{0}"}
#: C math functions printed by name (CasADi's ``casadi_fabs`` etc. are these in C99).
MATH = {ca.OP_EXP: "exp", ca.OP_LOG: "log", ca.OP_SQRT: "sqrt", ca.OP_SIN: "sin",
        ca.OP_COS: "cos", ca.OP_TAN: "tan", ca.OP_ASIN: "asin", ca.OP_ACOS: "acos",
        ca.OP_ATAN: "atan", ca.OP_FLOOR: "floor", ca.OP_CEIL: "ceil", ca.OP_FABS: "fabs",
        ca.OP_ERF: "erf", ca.OP_SINH: "sinh", ca.OP_COSH: "cosh", ca.OP_TANH: "tanh",
        ca.OP_ASINH: "asinh", ca.OP_ACOSH: "acosh", ca.OP_ATANH: "atanh",
        ca.OP_LOG1P: "log1p", ca.OP_EXPM1: "expm1"}


class LanesUnsupported(NotImplementedError):
    """The step uses an operation or a call the lane emitter does not translate."""


def _const(value: float) -> str:
    if math.isnan(value):
        return "NAN"
    if value in (float("inf"), float("-inf")):
        return "INFINITY" if value > 0 else "(-INFINITY)"
    return f"({float(value)!r})"


def _select(node: dict, x: str, y: str) -> str | None:
    """``if_else(c, a, b)`` as CasADi builds it, ``(c ? a : 0) + (!c ? b : 0)``, as one select.

    Exact: the sum is ``a + 0.0`` when ``c != 0`` (NaN included) and ``0.0 + b`` otherwise,
    and so is the select (the additions keep the sign of zero as the sum does).
    """
    nx, ny = node.get(x), node.get(y)
    if not (nx and ny and nx[0] == ny[0] == ca.OP_IF_ELSE_ZERO):
        return None
    (_, cx, ax), (_, cy, by) = nx, ny
    if node.get(cy) == (ca.OP_NOT, cx):
        return f"({cx}!=0 ? ({ax}+0.0) : (0.0+{by}))"
    if node.get(cx) == (ca.OP_NOT, cy):
        return f"({cy}!=0 ? (0.0+{by}) : ({ax}+0.0))"
    return None


def _program(f: ca.Function):
    """``(ops, call)``: per instruction ``(kind, data)`` in SSA form, and the call index."""
    cur, ops, call, node = {}, [], None, {}
    for k in range(f.n_instructions()):
        op, ins, outs = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        if op in (ca.OP_IF_ELSE_ZERO, ca.OP_NOT):
            node[f"v{k}"] = (op, *(cur[i] for i in ins))
        if op == ca.OP_INPUT:
            ops.append(("in", (ins[0], ins[1]), f"v{k}"))
        elif op == ca.OP_OUTPUT:
            ops.append(("out", (outs[0], outs[1]), cur[ins[0]]))
            continue
        elif op == ca.OP_CONST:
            ops.append(("let", _const(f.instruction_constant(k)), f"v{k}"))
        elif op == ca.OP_CALL:
            if call is not None:
                raise LanesUnsupported("more than one call in the step")
            call = len(ops)
            ops.append(("call", [cur[i] for i in ins], [f"c{j}" for j in range(len(outs))]))
            for j, o in enumerate(outs):
                cur[o] = f"c{j}"
            continue
        elif op == ca.OP_ADD and _select(node, cur[ins[0]], cur[ins[1]]):
            ops.append(("let", _select(node, cur[ins[0]], cur[ins[1]]), f"v{k}"))
        elif op in _BIN:
            ops.append(("let", _BIN[op].format(cur[ins[0]], cur[ins[1]]), f"v{k}"))
        elif op in _UN:
            ops.append(("let", _UN[op].format(cur[ins[0]]), f"v{k}"))
        elif op in MATH:
            ops.append(("let", f"{MATH[op]}({cur[ins[0]]})", f"v{k}"))
        else:
            raise LanesUnsupported(f"CasADi operation {op} has no lane translation")
        cur[outs[0]] = ops[-1][2]
    return ops, call


def _body(ops, load, store, rename) -> list[str]:
    """Statements of ``ops`` on lane ``l``; outputs stored last (in-place updates are safe)."""
    lines, stores = [], []
    for kind, data, name in ops:
        if kind == "in":
            lines.append(f"double {name} = {load(*data)};")
        elif kind == "let":
            lines.append(f"double {name} = {rename(data)};")
        elif kind == "out":
            stores.append(f"{store(*data)} = {rename(name)};")
    return lines + stores


def _segment(lines: list[str]) -> str:
    inner = "\n".join("    " + s for s in lines)
    return f"  #pragma omp simd\n  for (l = 0; l < FL_W; ++l) {{\n{inner}\n  }}\n"


def _acc_load(arg: int, nz: int) -> str:
    return f"A[{nz} * FL_W + l]" if arg == 0 else f"Dl[{nz} * FL_W + l]"


def _in_place(ops: list, call: int | None) -> tuple[list, int | None]:
    """Outputs that only copy their own input are dropped (the step updates ``A`` in place);
    with a call, every output moves after it (no input is overwritten before it is read)."""
    loads = {name: data for kind, data, name in ops if kind == "in"}
    kept = [op for op in ops if op[0] != "out" or loads.get(op[2]) != (0, op[1][1])]
    if call is None:
        return kept, None
    call = next(i for i, op in enumerate(kept) if op[0] == "call")
    before = [op for op in kept[:call] if op[0] != "out"]
    outs = [op for op in kept[:call] if op[0] == "out"]
    return before + [kept[call]] + kept[call + 1:] + outs, len(before)


def _step_body(acc: ca.Function, rk4: ca.Function | None, substeps: int) -> str:
    ops, call = _in_place(*_program(acc))
    store = lambda res, nz: f"A[{nz} * FL_W + l]"
    if call is None:
        return "  long l;\n" + _segment(_body(ops, _acc_load, store, str))
    if rk4 is None:
        raise LanesUnsupported("the step calls a function that is not the RK4 fold")
    (_, args, outs), before, after = ops[call], ops[:call], ops[call + 1:]
    defined = {name for kind, _, name in before if kind != "out"}
    used_after = sorted({tok for kind, data, name in after for tok in _tokens(data, name)}
                        & defined, key=lambda s: int(s[1:]))
    keep = {name: f"K[{i} * FL_W + l]" for i, name in enumerate(used_after)}
    n = len(outs)
    seg_a = _body(before, _acc_load, store, str)
    seg_a += [f"XS[{i} * FL_W + l] = {a};" for i, a in enumerate(args[:n])]
    seg_a += [f"US[l] = {args[n]};"] + [f"{keep[v]} = {v};" for v in used_after]
    rk_ops, rk_call = _program(rk4)
    if rk_call is not None:
        raise LanesUnsupported("the RK4 step calls a function")
    rk_load = lambda arg, nz: f"XS[{nz} * FL_W + l]" if arg == 0 else "US[l]"
    seg_b = _body(rk_ops, rk_load, lambda res, nz: f"XS[{nz} * FL_W + l]", str)
    seg_c = [f"double c{j} = XS[{j} * FL_W + l];" for j in range(n)]
    seg_c += _body(after, _acc_load, store, functools.partial(_rename, keep))
    return (f"  long l, sub;\n  double XS[{n} * FL_W] FL_ALIGN, US[FL_W] FL_ALIGN, "
            f"K[{max(1, len(used_after))} * FL_W] FL_ALIGN;\n" + _segment(seg_a)
            + f"  for (sub = 0; sub < {substeps}; ++sub) {{\n" + _segment(seg_b) + "  }\n"
            + _segment(seg_c))


def _tokens(data, name):
    import re

    text = data if isinstance(data, str) else ""
    return set(re.findall(r"\bv\d+\b", text)) | ({name} if isinstance(name, str) else set())


def _rename(keep: dict, text: str) -> str:
    import re

    return re.sub(r"\bv\d+\b", lambda m: keep.get(m.group(0), m.group(0)), text)


def rk4_fold(accumulate: ca.Function) -> tuple[ca.Function | None, int]:
    """The single RK4 step that ``accumulate`` calls as a fold, and the number of substeps.

    ``(None, 1)`` when the step calls nothing (one substep, inlined).

    Parameters
    ----------
    accumulate : casadi.Function
        The accumulating step ``fl_acc``.

    Returns
    -------
    (casadi.Function or None, int)

    Raises
    ------
    LanesUnsupported
        The step calls something else.

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design.sim.kernel._emit import rk4_fold
    >>> x = ca.SX.sym("x")
    >>> rk4_fold(ca.Function("f", [x], [2 * x]))
    (None, 1)
    """
    called = {fn.name(): fn for fn in accumulate.find_functions()}
    if not called:
        return None, 1
    step, fold = called.get("fl_rk4_step"), called.get("fold_fl_rk4_step")
    if step is None or fold is None or "fl_rk4" not in called:
        raise LanesUnsupported(f"the step calls {sorted(called)}, not the RK4 fold")
    return step, int(fold.size2_in(1))


@functools.lru_cache(maxsize=1)
def _template() -> str:
    return resources.files(__package__).joinpath("templates/lanes_driver.c.in").read_text()


def lanes_source(accumulate: ca.Function, indices: dict, *, width: int,
                 vector_math: tuple[str, ...] = ()) -> str:
    """C source of the lane step and its driver ``fl_lanes_run`` (see the module docstring).

    Parameters
    ----------
    accumulate : casadi.Function
        ``fl_acc(acc, d) -> acc_next`` (SX; plant step inlined or a call to the RK4 fold).
    indices : dict
        Accumulator positions ``k``, ``div``, ``N``.
    width : int
        Lanes W per vector.
    vector_math : tuple of str, optional
        Math functions declared ``omp declare simd`` (vector versions in libmvec).

    Returns
    -------
    str

    Raises
    ------
    LanesUnsupported
        An operation without translation.

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design.sim.kernel._emit import lanes_source
    >>> x = ca.SX.sym("x", 3)
    >>> src = lanes_source(ca.Function("fl_acc", [x, ca.SX.sym("d", 2)], [x]),
    ...                    {"k": 0, "div": 1, "N": 2}, width=8)
    >>> "#define FL_W 8" in src
    True
    """
    from ._runners import fill_template

    rk4, substeps = rk4_fold(accumulate)
    decls = "".join(f"#pragma omp declare simd notinbranch\ndouble {name}(double);\n"
                    for name in vector_math)
    return fill_template(_template(), {
        "W": int(width), "NACC": accumulate.size1_in(0), "ND": accumulate.size1_in(1),
        "I_K": indices["k"],
        "I_DIV": indices["div"], "I_N": indices["N"], "VECTOR_MATH": decls,
        "STEP_BODY": _step_body(accumulate, rk4, substeps)})


__all__ = ["LanesUnsupported", "lanes_source", "rk4_fold"]
