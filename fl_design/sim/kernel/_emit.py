"""C for W grid points at once, emitted from the SX instruction list of the accumulating step.

:func:`lanes_source` walks the instructions of ``fl_acc`` (and, when the plant step is a call
to ``fold(fl_rk4_step)``, those of the single RK4 step) and writes each one as a C statement
on a vector of ``FL_V`` doubles, one lane per run (:mod:`fl_design.sim.kernel._vector`: explicit
vector types, so the step is vectorised whatever the compiler's auto-vectoriser makes of it):
the accumulators are stored structure-of-arrays (``A[i * FL_W + l]``, updated in place: an
accumulator entry the step only copies is not touched), every instruction result is a fresh
local, and math calls go to glibc's libmvec where it has them. Each statement is written for
:func:`groups` independent lane groups (``FL_W = groups * FL_V`` runs per block), so the
dependent ``tanh`` calls of the RK4 stages of one group overlap with the other's. The RK4
substeps are unrolled (the state stays in registers; what depends only on the held input is
computed once per sample); beyond :data:`UNROLL_LINES` they run as a C loop over blocks of
unrolled substeps, so the source stops growing with their number. Nothing is written by
hand: an operation the tables do not know raises :class:`LanesUnsupported` and the caller
keeps the scalar kernel.

Selects are written with fewer instructions and the same bits
(:mod:`fl_design.sim.kernel._selects`: a select of a select or extremum sharing a value is
one select; the ``+ 0.0`` of a select of values that cannot be ``-0.0`` or a signalling NaN
is dropped, the kernel's ``fl_lanes_check`` vetting the initial values this assumes).
Operations are printed as CasADi's code generator prints them (``casadi_sq(x) = x*x``,
``c ? a : 0`` as a lane mask, ``fmin``/``fmax`` as glibc computes them on x86-64,
``casadi_sign``), and the kernel is compiled without floating-point contraction, so a lane
computes what the scalar kernel and the interpreter compute (up to the last bits of libmvec's
vector ``tanh``, ``sin``, ... against glibc's scalar ones).

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
import re
from importlib import resources

import casadi as ca

from ..._cmath import ELEMENTARY
from ._order import hoist
from ._order import in_place as _in_place
from ._selects import EXTREMA, Zeros, merged, select_parts
from ._vector import BINARY, BINARY_MATH, UNARY, constant, load, prelude, store

#: C math functions printed by name (CasADi's ``casadi_fabs`` etc. are these in C99).
MATH = {**ELEMENTARY, ca.OP_FABS: "fabs"}


class LanesUnsupported(NotImplementedError):
    """The step uses an operation or a call the lane emitter does not translate."""


def _const(value: float) -> str:
    if math.isnan(value):
        return "NAN"
    if value in (float("inf"), float("-inf")):
        return "INFINITY" if value > 0 else "(-INFINITY)"
    return f"({float(value)!r})"


def _select(node: dict, x: str, y: str, mask) -> str | None:
    """``if_else(c, a, b)`` as CasADi builds it, ``(c ? a : 0) + (!c ? b : 0)``, as one select.

    Exact: the sum is ``a + 0.0`` when ``c != 0`` (NaN included) and ``0.0 + b`` otherwise,
    and so is the select plus ``0.0`` (the addition turns ``-0.0`` into ``+0.0`` as the sum
    does, and quiets a NaN as the sum does; one addition instead of one per branch).
    """
    parts = select_parts(node, x, y, mask)
    return None if parts is None else "(FL_SEL({}, {}, {})+FL_Z)".format(*parts)


#: Operations whose value is a truth value (``1.0`` or ``+0.0``), written as a lane mask.
_MASKS = {ca.OP_LT: "({0}<{1})", ca.OP_LE: "({0}<={1})", ca.OP_EQ: "({0}=={1})",
          ca.OP_NE: "({0}!={1})", ca.OP_AND: "({m0} & {m1})", ca.OP_OR: "({m0} | {m1})",
          ca.OP_NOT: "(~{m0})"}


def _program(f: ca.Function, zeros: Zeros | None = None):
    """``(ops, call)``: per instruction ``(kind, data)`` in SSA form, and the call index.

    A truth value (comparison, and, or, not, the product of two truth values) is also kept
    as a lane mask, named ``v<n + k>`` for instruction ``k`` of ``n`` (stored in a vector's
    bits): a condition on it (``if_else``, ``and``...) uses the mask directly instead of
    comparing ``1.0``/``0.0`` with zero again (the same lanes are selected). Selects are
    merged (:func:`fl_design.sim.kernel._selects.merged`); with ``zeros`` (the accumulating
    step: input 0 is the accumulator), a select of two normal values loses its ``+ 0.0``
    (:class:`fl_design.sim.kernel._selects.Zeros`; ``zeros`` then holds the entries whose
    initial values must be normal).
    """
    cur, ops, call, node, masks, selects = {}, [], None, {}, {}, {}
    reduce, zeros = zeros is not None, zeros if zeros is not None else Zeros()
    n = f.n_instructions()

    def mask(x: str) -> str:  # lanes where x != 0 (NaN included)
        return f"FL_M({masks[x]})" if x in masks else f"({x}!=FL_Z)"

    for k in range(n):
        op, ins, outs = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        if op in (ca.OP_IF_ELSE_ZERO, ca.OP_NOT):
            node[f"v{k}"] = (op, *(cur[i] for i in ins))
        args = [cur[i] for i in ins] if op not in (ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST) \
            else []
        if op == ca.OP_MUL and all(a in masks for a in args):  # 1.0 or +0.0 times the same
            op_mask = f"(FL_M({masks[args[0]]}) & FL_M({masks[args[1]]}))"
        elif op in _MASKS:
            op_mask = _MASKS[op].format(*args, m0=mask(args[0]), m1=mask(args[-1]))
        else:
            op_mask = None
        name = f"v{k}"
        if op_mask is not None:
            masks[name] = f"v{n + k}"
            ops.append(("let", f"((fl_v){op_mask})", f"v{n + k}"))
            ops.append(("let", f"FL_B(FL_M(v{n + k}))", name))
            zeros.fact(name, "normal")  # 1.0 or +0.0
        elif op == ca.OP_INPUT:
            ops.append(("in", (ins[0], ins[1]), name))
            if ins[0] == 0:
                zeros.fact(name, "load", ins[1])
        elif op == ca.OP_OUTPUT:
            ops.append(("out", (outs[0], outs[1]), cur[ins[0]]))
            if outs[0] == 0:
                zeros.stores[outs[1]] = cur[ins[0]]
            continue
        elif op == ca.OP_CONST:
            value = f.instruction_constant(k)
            ops.append(("let", constant(_const(value)), name))
            if not (value == 0 and math.copysign(1, value) < 0):
                zeros.fact(name, "normal")  # NAN is a quiet NaN
        elif op == ca.OP_CALL:
            if call is not None:
                raise LanesUnsupported("more than one call in the step")
            call = len(ops)
            ops.append(("call", args, [f"c{j}" for j in range(len(outs))]))
            for j, o in enumerate(outs):
                cur[o] = f"c{j}"
            continue
        elif op == ca.OP_ADD and select_parts(node, *args, mask):
            parts = selects[name] = merged(select_parts(node, *args, mask), selects)
            zeros.selects.append((len(ops), parts))
            zeros.fact(name, "normal")  # plus 0.0, or (below) two normal values
            ops.append(("let", "(FL_SEL({}, {}, {})+FL_Z)".format(*parts), name))
        elif op == ca.OP_IF_ELSE_ZERO:
            ops.append(("let", f"FL_AND({mask(args[0])}, {args[1]})", name))
            zeros.fact(name, "and", args[1])
        elif op in BINARY:
            if op in EXTREMA:  # FL_SEL(mask, a, b) without + 0: a select to merge into
                selects[name] = (EXTREMA[op].format(*args), *args)
                zeros.fact(name, "sel", *args)
            elif op in (ca.OP_ADD, ca.OP_SUB):
                zeros.fact(name, "add" if op == ca.OP_ADD else "sub", *args)
            elif op in (ca.OP_MUL, ca.OP_DIV, ca.OP_POW, ca.OP_CONSTPOW):
                zeros.fact(name, "quiet")
            ops.append(("let", BINARY[op].format(*args), name))
        elif op in UNARY:
            ops.append(("let", UNARY[op].format(*args), name))
            if op in (ca.OP_SQ, ca.OP_TWICE, ca.OP_INV):
                zeros.fact(name, "quiet")
        elif op in MATH:
            ops.append(("let", f"fl_{MATH[op]}({args[0]})", name))
            zeros.fact(name, "fabs", args[0]) if op == ca.OP_FABS else zeros.fact(name, "quiet")
        else:
            raise LanesUnsupported(f"CasADi operation {op} has no lane translation")
        cur[outs[0]] = name
    for i in zeros.solve()[1] if reduce else ():
        kind, text, name = ops[i]
        ops[i] = (kind, text[1:-len("+FL_Z)")], name)  # "(FL_SEL(...)+FL_Z)" -> "FL_SEL(...)"
    return ops, call


def _body(ops, ref, target, rename) -> list[str]:
    """Statements of ``ops`` (vectors of lanes ``l``...), in their order (see :func:`_in_place`)."""
    lines = []
    for kind, data, name in ops:
        if kind == "in":
            lines.append(f"fl_v {name} = {load(ref(*data))};")
        elif kind == "let":
            lines.append(f"fl_v {name} = {rename(data)};")
        elif kind == "out":
            lines.append(store(target(*data), rename(name)))
    return lines


def groups(width: int, substeps: int, *, clang: bool = False) -> int:
    """Independent lane groups per block: every statement is written ``groups`` times, for
    lanes ``l``, ``l + FL_V``, ... (``FL_W = groups * FL_V`` lanes per block), so the
    out-of-order core overlaps the latency of one vector ``tanh`` (34 ns at 4 lanes on AVX2
    and at 8 on AVX-512; its throughput 11-13 ns) with the other groups': the RK4 stages are
    a chain of dependent calls.

    Measured on the TRMS sweep step (106 accumulators; ns per run-sample, one thread, Xeon
    with AVX-512, GCC 12, load 2-3): one substep, AVX2 2/4 groups 46.7/47.1, AVX-512
    27.5/30.9 (4 groups: twice the code, compiled in 0.84 s instead of 0.35 s); 10 substeps,
    AVX2 2/4/8 groups 246/179/191, AVX-512 137/113/120. The width does not change the choice.
    Clang 14 (``clang=True``) is faster with 4 groups in every case (one substep: AVX2 2/4
    groups 46.5/41.8, AVX-512 24.4/22.6; 10 substeps 242/175 and 134/108) and compiles them
    in 0.5 s. With the select rewrites (:mod:`fl_design.sim.kernel._selects`) and the values
    computed once per run, still 4 (AVX2, Clang, load 2.5-3.5: 2/3/4/5 groups
    37.8/33.4/32.7/32.2-33.1).

    Examples
    --------
    >>> from fl_design.sim.kernel._emit import groups
    >>> groups(8, 1), groups(4, 1), groups(8, 10), groups(8, 1, clang=True)
    (2, 2, 4, 4)
    """
    return 2 if substeps == 1 and not clang else 4


_DEFINED = re.compile(r"^(?:const )?fl_v (\w+) =")
_WORD = re.compile(r"\b\w+\b")


def _segment_groups(lines: list[str], groups: int) -> str:
    """A block running ``lines`` (vector statements written for the lanes from ``l``) on each
    of ``groups`` lane groups, statements interleaved."""
    names = {m.group(1) for m in map(_DEFINED.match, lines) if m}

    def copy(g: int) -> list[str]:  # whole words only: a local gets _g<g>, the lane l is l<g>
        rename = {**{name: f"{name}_g{g}" for name in names}, "l": f"l{g}"}
        sub = lambda m: rename.get(m.group(0), m.group(0))
        return [_WORD.sub(sub, line) for line in lines]

    copies = [copy(g) for g in range(groups)]
    lanes = ", ".join(f"l{g} = {g} * FL_V" for g in range(groups))
    inner = "\n".join("    " + line for group in zip(*copies) for line in group)
    return f"  {{\n    const long {lanes};\n{inner}\n  }}\n"


def _acc_load(arg: int, nz: int) -> str:
    return f"A[{nz} * FL_W + l]" if arg == 0 else f"Dl[{nz} * FL_W + l]"


#: Most statements (per lane group) of substeps unrolled in one block. The substeps are
#: straight-line code: the state stays in registers, nothing is stored or reloaded between
#: substeps. A step whose substeps all fit in :data:`UNROLL_LINES` is one block (TRMS, 10 substeps: 2 % faster than blocks
#: of 5); more substeps run as a C loop over blocks of :data:`BLOCK_LINES`, the state stored
#: between blocks (compile time stays about a second for any number of substeps).
UNROLL_LINES = 2400
BLOCK_LINES = 600


def _step_body(acc: ca.Function, rk4: ca.Function | None, substeps: int, width: int,
               n_groups: int | None = None, zeros: Zeros | None = None
               ) -> tuple[str, int, str, int]:
    """C of ``fl_lanes_step``, its number of lane groups (default :func:`groups`), C of
    ``fl_lanes_init`` and the number of values it computes once per run
    (:func:`fl_design.sim.kernel._order.hoist`); ``zeros`` (filled) drops the ``+ 0.0`` of
    selects of normal values."""
    n_groups = n_groups or groups(width, substeps)
    _segment = functools.partial(_segment_groups, groups=n_groups)
    ops, call = _in_place(*_program(acc, zeros))
    ops, init, n_init = hoist(ops, int(acc.size1_in(0)))
    store_at = lambda res, nz: f"A[{nz} * FL_W + l]"
    init_c = _segment(_body(init, _acc_load, store_at, str)) if n_init else ""
    if call is None:
        return _segment(_body(ops, _acc_load, store_at, str)), n_groups, init_c, n_init
    step, n_groups = _call_body(ops, call, rk4, substeps, n_groups, _segment, store_at)
    return step, n_groups, init_c, n_init


def _call_body(ops, call, rk4, substeps, n_groups, _segment, store_at) -> tuple[str, int]:
    """:func:`_step_body` of a step calling the RK4 fold (its substeps unrolled)."""
    if rk4 is None:
        raise LanesUnsupported("the step calls a function that is not the RK4 fold")
    (_, args, outs), before, after = ops[call], ops[:call], ops[call + 1:]
    rk_ops, rk_call = _program(rk4)
    if rk_call is not None:
        raise LanesUnsupported("the RK4 step calls a function")
    n = len(outs)
    hoisted, body, rk_outs = _substep_parts(rk_ops, n)
    per_substep = max(1, len(body) * n_groups)
    unroll = substeps if substeps * per_substep <= UNROLL_LINES else \
        max(1, min(substeps, BLOCK_LINES // per_substep))
    xs = [f"xs{i}" for i in range(n)]
    if unroll == substeps:  # one lane loop: the step, its substeps and the metrics
        lines = _body(before, _acc_load, store_at, str)
        lines += [f"fl_v {x} = {a};" for x, a in zip(xs, args[:n])]
        lines += [f"const fl_v us = {args[n]};", *hoisted]
        state, unrolled = _unrolled(body, rk_outs, xs, substeps)
        lines += unrolled + [f"fl_v c{j} = {state[j]};" for j in range(n)]
        return _segment(lines + _body(after, _acc_load, store_at, str)), n_groups
    defined = {name for kind, _, name in before if kind != "out"}
    used_after = sorted({tok for kind, data, name in after for tok in _tokens(data, name)}
                        & defined, key=lambda s: int(s[1:]))
    keep = {name: f"K[{i} * FL_W + l]" for i, name in enumerate(used_after)}
    seg_a = _body(before, _acc_load, store_at, str)
    seg_a += [store(f"XS[{i} * FL_W + l]", a) for i, a in enumerate(args[:n])]
    seg_a += [store("US[l]", args[n])] + [store(keep[v], v) for v in used_after]

    def block(count: int) -> str:
        lines = [f"fl_v {x} = {load(f'XS[{i} * FL_W + l]')};" for i, x in enumerate(xs)]
        lines += [f"const fl_v us = {load('US[l]')};", *hoisted]
        state, unrolled = _unrolled(body, rk_outs, xs, count)
        return _segment(lines + unrolled + [store(f"XS[{i} * FL_W + l]", v)
                                             for i, v in enumerate(state)])

    seg_c = [f"fl_v c{j} = {load(f'XS[{j} * FL_W + l]')};" for j in range(n)]
    seg_c += _body(after, _acc_load, store_at, functools.partial(_rename, keep))
    rest = substeps % unroll
    return (f"  long sub;\n  double XS[{n} * FL_W] FL_ALIGN, US[FL_W] FL_ALIGN, "
            f"K[{max(1, len(used_after))} * FL_W] FL_ALIGN;\n" + _segment(seg_a)
            + f"  for (sub = 0; sub < {substeps // unroll}; ++sub) {{\n" + block(unroll)
            + "  }\n" + (block(rest) if rest else "") + _segment(seg_c)), n_groups


def _substep_parts(rk_ops: list, n: int) -> tuple[list[str], list[tuple[str, str]], list[str]]:
    """One RK4 substep on the state ``xs0..`` and the held input ``us``: the statements that
    depend only on ``us`` and constants (the plant's drive term, ...; computed once per sample,
    the same operations on the same values), the others as ``(name, expression)``, and the
    names of the next state."""
    ren = lambda text: re.sub(r"\bv(\d+)\b", r"s\1", text)
    load = lambda arg, nz: f"xs{nz}" if arg == 0 else "us"
    invariant: set[str] = set()
    hoisted, body, outs = [], [], {}
    for kind, data, name in rk_ops:
        if kind == "out":
            outs[data[1]] = ren(name)
            continue
        text = load(*data) if kind == "in" else ren(data)
        deps = set(re.findall(r"\b(?:s\d+|xs\d+)\b", text))
        if (kind == "in" and data[0] == 1) or (kind == "let" and deps <= invariant):
            invariant.add(ren(name))
            hoisted.append(f"fl_v {ren(name)} = {text};")
        else:
            body.append((ren(name), text))
    if sorted(outs) != list(range(n)):
        raise LanesUnsupported("the RK4 step does not return every state")
    return hoisted, body, [outs[i] for i in range(n)]


def _unrolled(body: list, outs: list[str], xs: list[str], count: int):
    """``count`` copies of the substep ``body`` chained (copy ``j``'s names end in ``_j``);
    ``(state names after the last copy, statements)``."""
    local = {name for name, _ in body}
    state, lines = list(xs), []
    for j in range(count):
        sub = {**{x: state[i] for i, x in enumerate(xs)},
               **{name: f"{name}_{j}" for name in local}}
        rename = lambda text, sub=sub: re.sub(r"\b(?:s\d+|xs\d+)\b",
                                              lambda m: sub.get(m.group(0), m.group(0)), text)
        lines += [f"fl_v {name}_{j} = {rename(text)};" for name, text in body]
        state = [rename(o) for o in outs]
    return state, lines


def _tokens(data, name):
    text = data if isinstance(data, str) else ""
    return set(re.findall(r"\bv\d+\b", text)) | ({name} if isinstance(name, str) else set())


def _rename(keep: dict, text: str) -> str:
    return re.sub(r"\bv\d+\b", lambda m: load(keep[m.group(0)]) if m.group(0) in keep
                  else m.group(0), text)


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


def fill_template(text: str, values: dict) -> str:
    """Replace every ``@NAME@`` in ``text`` by ``values[NAME]``; unknown names are an error.

    Examples
    --------
    >>> from fl_design.sim.kernel._emit import fill_template
    >>> fill_template("int n = @N@;", {"N": 3})
    'int n = 3;'
    """
    import re

    def sub(match):
        key = match.group(1)
        if key not in values:
            raise KeyError(f"template placeholder @{key}@ has no value")
        return str(values[key])

    return re.sub(r"@([A-Z_][A-Z0-9_]*)@", sub, text)


def lanes_source(accumulate: ca.Function, indices: dict, *, width: int,
                 vector_math: tuple[str, ...] = (), variant: str | None = None,
                 groups: int | None = None) -> str:
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
        Math functions taken from libmvec (their vector versions exist at this level).
    variant : str, optional
        libmvec's letter for this level (``d`` for AVX2...; :attr:`fl_design._isa.Isa.mvec`);
        without it every math function is called lane by lane.
    groups : int, optional
        Lane groups per block (default :func:`groups`).

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
    >>> "#define FL_V 8" in src
    True
    """
    rk4, substeps = rk4_fold(accumulate)
    zeros = Zeros()
    step, n_groups, init, n_init = _step_body(accumulate, rk4, substeps, int(width), groups,
                                              zeros)
    normal = sorted(zeros.solve()[0])
    known = {*MATH.values(), *BINARY_MATH}
    used = {name for name in re.findall(r"\bfl_(\w+)\(", step) if name in known}
    return fill_template(_template(), {
        "W": int(width), "G": n_groups, "NACC": accumulate.size1_in(0),
        "ND": accumulate.size1_in(1), "I_K": indices["k"],
        "I_DIV": indices["div"], "I_N": indices["N"],
        "VECTOR_MATH": prelude(int(width), tuple(vector_math), variant, used),
        "N_NORMAL": len(normal), "NORMAL": ", ".join(map(str, normal or [0])),
        "STEP_BODY": step, "N_INIT": n_init, "INIT_BODY": init})


__all__ = ["LanesUnsupported", "fill_template", "lanes_source", "rk4_fold"]
