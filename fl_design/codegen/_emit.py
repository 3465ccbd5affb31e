"""Straight-line C of an SX function's instruction list: the body of the generated step.

Every instruction becomes one ``const`` local (SSA), printed so that no compiler flag changes
what it computes and no library call is left: ``fmin``/``fmax`` as ``?:`` selects (the step
never sees a NaN: the wrapper rejects it first), comparisons as ``int`` locals (so no float is
ever used as a truth value: ``-Wfloat-conversion``, ``-Wfloat-equal`` clean; ``bool`` locals of
``<stdbool.h>``, MISRA C's essentially Boolean type), CasADi's
``if_else`` pattern ``(c ? a : 0) + (!c ? b : 0)`` as one select, a comparison of a *switch*
input (a C ``int`` holding 0 or 1, e.g. ``p->antiwindup``) with a constant as an integer test
(``p->antiwindup != 0``: no conversion, no floating compare), literals in the build's
precision (``f``-suffixed in float: ``-Wdouble-promotion`` clean). Elementary functions the
library's estimators never use (``sin``, ``sqrt``...) are printed as ``<math.h>`` calls in the
build's precision and reported by :func:`math_calls`.

A saturation ``min(max(v, lo), hi)`` whose result is afterwards compared with its own bounds
(``hi <= u``, ``u <= lo``: the conditional-integration test) is printed as one ``if``/``else``
whose unsaturated branch (``lo < v < hi``) knows both tests false, so the common path tests
``v`` twice and nothing else; the two saturated branches compute the selects and the tests as
written. It computes what the two selects and the two comparisons compute for every ``v``,
``lo`` and ``hi`` (NaN, crossed bounds included).

Examples
--------
>>> import casadi as ca
>>> from fl_design.codegen._emit import c_body
>>> x = ca.SX.sym("x")
>>> f = ca.Function("f", [x], [ca.fmin(ca.fmax(3 * x, 0), 1)])
>>> print(c_body(f, [["x"]], [["*u"]], "float"))  # doctest: +NORMALIZE_WHITESPACE
  const float a0 = 3.0f;
  const float a2 = (a0*x);
  const float a3 = 0.0f;
  const float a4 = (a2 > a3 ? a2 : a3);
  const float a5 = 1.0f;
  const float a6 = (a4 < a5 ? a4 : a5);
  *u = a6;
"""

from __future__ import annotations

import math
import operator
import re

import casadi as ca

from .._cmath import ELEMENTARY
from ..errors import ComputationError
from ..sim.kernel._emit import _select as _lane_select
from ._finite import check_terms

_ARITH = {ca.OP_ADD: "({0}+{1})", ca.OP_SUB: "({0}-{1})", ca.OP_MUL: "({0}*{1})",
          ca.OP_DIV: "({0}/{1})", ca.OP_FMIN: "({0} < {1} ? {0} : {1})",
          ca.OP_FMAX: "({0} > {1} ? {0} : {1})"}
_COMPARE = {ca.OP_LT: "({0} < {1})", ca.OP_LE: "({0} <= {1})",
            ca.OP_EQ: "!({0} < {1} || {0} > {1})", ca.OP_NE: "({0} < {1} || {0} > {1})"}
_TRUTH = {ca.OP_LT: operator.lt, ca.OP_LE: operator.le, ca.OP_EQ: operator.eq,
          ca.OP_NE: operator.ne}
_LOGIC = {ca.OP_AND: "({0} && {1})", ca.OP_OR: "({0} || {1})"}
_UNARY = {ca.OP_NEG: "(-{0})", ca.OP_SQ: "({0}*{0})", ca.OP_ASSIGN: "{0}",
          ca.OP_FABS: "({0} < {z} ? -{0} : {0})", ca.OP_TWICE: "({0}+{0})"}
#: elementary functions printed as <math.h> calls (``f`` variant in float)
MATH = {**ELEMENTARY, ca.OP_POW: "pow", ca.OP_CONSTPOW: "pow", ca.OP_ATAN2: "atan2"}


def literal(value: float, real: str) -> str:
    """``value`` as a C literal of type ``real`` (finite values only).

    Parameters
    ----------
    value : float
        The number.
    real : {"double", "float"}
        The build's type.

    Returns
    -------
    str

    Raises
    ------
    ComputationError
        ``value`` is not finite (a step constant must be: ``-ffast-math`` assumes it).

    Examples
    --------
    >>> from fl_design.codegen._emit import literal
    >>> literal(-2.0, "float"), literal(1e-3, "double"), literal(3.0, "double")
    ('(-2.0f)', '0.001', '3.0')
    """
    if not math.isfinite(value):
        raise ComputationError(f"the step has a non-finite constant {value!r}; C literals "
                               "must be finite (the build may assume it: -ffast-math)")
    text = repr(float(value)) + ("f" if real == "float" else "")
    return f"({text})" if text.startswith("-") else text


class _Namer:
    """The current C name and kind (``"real"`` or ``"int"``) of each work-vector entry."""

    def __init__(self, real: str):
        self.real, self.name, self.kind = real, {}, {}

    def as_real(self, w: int) -> str:
        return self.name[w] if self.kind[w] == "real" else f"(({self.real}) {self.name[w]})"

    def as_bool(self, w: int) -> str:
        if self.kind[w] in ("int", "switch"):
            return self.name[w]
        z = literal(0.0, self.real)
        return f"({self.name[w]} < {z} || {self.name[w]} > {z})"


class _Lanes:
    """The view of a ``{id: ("ifz", c, x) | ("not", c)}`` table that the lane emitter's
    matcher reads: names ``a<id>`` and CasADi's operation codes."""

    def __init__(self, node: dict):
        self.node = node

    def get(self, name: str):
        entry = self.node.get(int(name[1:]))
        if entry is None:
            return None
        op = ca.OP_IF_ELSE_ZERO if entry[0] == "ifz" else ca.OP_NOT
        return (op, *(f"a{v}" for v in entry[1:]))


def _select(node: dict, a: int, b: int):
    """``(c ? x : 0) + (!c ? y : 0)`` (CasADi's ``if_else``) as ``(c, x, y)``, else None.

    The match is :func:`fl_design.sim.kernel._emit._select`'s (one home for the pattern): its
    select names ``c``, ``x`` and ``y`` in that order.
    """
    text = _lane_select(_Lanes(node), f"a{a}", f"a{b}", lambda c: c)  # c's name as it is
    if text is None:
        return None
    c, x, y = (int(v) for v in re.findall(r"\ba(\d+)\b", text))
    return c, x, y


def _switch_test(op: int, args, names: _Namer, consts: dict):
    """A comparison of a switch (an ``int``, 0 or 1) with a constant as an ``int`` test:
    ``(text, switch)``, or None."""
    a, b = args
    for s, c, first in ((a, b, True), (b, a, False)):
        if names.kind.get(s) == "switch" and c in consts:
            truth = tuple(_TRUTH[op](v, consts[c]) if first else _TRUTH[op](consts[c], v)
                          for v in (0, 1))
            return {(False, True): f"({names.name[s]} != 0)",
                    (True, False): f"({names.name[s]} == 0)"}.get(truth, str(int(truth[0]))), s
    return None


def c_body(f: ca.Function, inputs, outputs, real: str, *, indent: str = "  ",
           switches=frozenset(), rare: str = "", check: str = "", required=((), ()),
           keys=None) -> str:
    """The statements computing ``f``'s outputs from its inputs (see the module docstring).

    Parameters
    ----------
    f : casadi.Function
        An SX function.
    inputs : list of list of str
        C expression of each input's nonzero ``j`` (``inputs[i][j]``).
    outputs : list of list of str
        C lvalue of each output's nonzero.
    real : {"double", "float"}
        Floating type.
    indent : str, optional
        Line prefix.
    switches : collection of str, optional
        Input expressions that are C ``int`` holding 0 or 1 (compared as integers).
    rare : str, optional
        A macro ``RARE(c)`` the saturation's two tests are wrapped in (e.g. a
        ``__builtin_expect`` hint that ``u`` is mostly within its limits); "" for none.
    check : str, optional
        A C lvalue given the sum of the finiteness test's terms (:mod:`._finite`: finite
        whenever every required value is; "" for none).
    required : tuple of two collections of int, optional
        The inputs and the outputs (indices) whose every nonzero must be finite when the
        check's sum is.
    keys : dict, optional
        An integer test of a saturation's unsaturated branch: ``{"bounds": (lo, hi), "fn":
        key, "lo1": ..., "span": ...}`` (C texts) for the saturation whose bounds print as
        ``lo`` and ``hi``: it is taken when ``key(v) - lo1 < span`` (unsigned), which the
        caller makes equivalent to ``lo < v < hi`` for every finite ``v`` and false for a NaN
        or an infinite one (the order key of the bit pattern, :file:`step.c.in`). That branch
        then proves ``v`` finite with no floating-point compare, so ``v`` leaves the check's
        sum there (the other branches add it). ``"test"``: another test (a format string of
        ``v``, true outside), with ``"proves": False`` when it does not prove ``v`` finite
        (``v`` then stays in the sum). With ``"bail": lvalue`` only the unsaturated branch is
        printed and ``lvalue`` says whether it was not taken (the caller then computes the
        step another way). None: the float compares alone.

    Returns
    -------
    str

    Raises
    ------
    ComputationError
        An operation without a translation.

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design.codegen._emit import c_body
    >>> x = ca.SX.sym("x")
    >>> "a2 = (x < a1);" in c_body(ca.Function("f", [x], [x < 1]), [["x"]], [["*o"]], "double")
    True
    >>> s = ca.SX.sym("s")
    >>> g = ca.Function("g", [x, s], [ca.if_else(s > 0.5, x, 2 * x)])
    >>> "(on != 0) ? x :" in c_body(g, [["x"], ["on"]], [["*o"]], "float", switches={"on"})
    True
    >>> u = ca.fmin(ca.fmax(x, -1), 1)
    >>> h = ca.Function("h", [x, s], [u, ca.if_else(u >= 1, s, 0)])
    >>> print(c_body(h, [["x"], ["s"]], [["*u"], ["*o"]], "float"))  # doctest: +NORMALIZE_WHITESPACE
      const float a1 = (-1.0f);
      const float a3 = 1.0f;
      float a4;
      bool a4_hi = false;
      if (!(x > a1)) {
        a4 = (a1 < a3 ? a1 : a3);
        a4_hi = (a3 <= a4);
      } else if (!(x < a3)) {
        a4 = a3;
        a4_hi = (a3 <= a4);
      } else {
        a4 = x;  /* lo < v < hi: no test holds */
      }
      const float a8 = ((a4_hi) ? s : 0.0f);
      *u = a4;
      *o = a8;
    """
    names, lines, stores, node, live, consts = _Namer(real), [], [], {}, set(), {}
    sources = []  # (output lvalue, node) of every store
    cur = {}  # work index -> SSA id (int)
    blocks, bound_tests = _saturations(f)
    graph, needed = {}, []  # the finiteness test's view of each node (._finite)
    for k in range(f.n_instructions()):
        op, ins, outs = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        if op == ca.OP_OUTPUT:
            w = cur[ins[0]]
            stores.append(f"{indent}{outputs[outs[0]][outs[1]]} = {names.as_real(w)};")
            sources.append((outputs[outs[0]][outs[1]], w))
            live.add(w)
            if outs[0] in required[1]:
                needed.append(w)
            continue
        args = [cur[i] for i in ins if i >= 0] if op not in (ca.OP_INPUT, ca.OP_CONST) else []
        kind, text = "real", None
        graph[k] = (_FINITE_KIND.get(op, "other"), tuple(args))
        if op == ca.OP_INPUT:
            name = inputs[ins[0]][ins[1]]
            names.name[k], names.kind[k] = name, "switch" if name in switches else "real"
            cur[outs[0]] = k
            graph[k] = ("int" if name in switches else "input", ())
            if ins[0] in required[0]:
                needed.append(k)
            continue
        if op == ca.OP_CONST:
            consts[k] = f.instruction_constant(k)
            text = literal(consts[k], real)
        elif k in blocks:  # min(max(v, lo), hi) tested against its bounds: one if/else
            args = list(blocks[k])
            graph[k] = ("sat", tuple(args))
            names.name[k], names.kind[k] = f"a{k}", "real"
            lines.append((k, args, None))  # printed below, with the check's terms
            cur[outs[0]] = k
            continue
        elif k in bound_tests:  # hi <= u or u <= lo of a saturation: its branch's flag
            kind, text, args = "int", f"a{bound_tests[k][0]}_{bound_tests[k][1]}", [bound_tests[k][0]]
        elif op == ca.OP_ADD and _select(node, *args):
            c, x, y = args = _select(node, *args)
            graph[k] = ("select", (x, y))
            text = f"({names.as_bool(c)} ? {names.as_real(x)} : {names.as_real(y)})"
        elif op == ca.OP_IF_ELSE_ZERO:
            node[k] = ("ifz", args[0], args[1])
            graph[k] = ("select", (args[1],))  # c ? a : 0
            text = (f"({names.as_bool(args[0])} ? {names.as_real(args[1])} : "
                    f"{literal(0.0, real)})")
        elif op in _ARITH:
            text = _ARITH[op].format(*(names.as_real(a) for a in args))
        elif op in _COMPARE and _switch_test(op, args, names, consts) is not None:
            text, switch = _switch_test(op, args, names, consts)
            kind, args = "int", [switch]  # the constant is not read
        elif op in _COMPARE:
            kind, text = "int", _COMPARE[op].format(*(names.as_real(a) for a in args))
        elif op in _LOGIC:
            kind, text = "int", _LOGIC[op].format(*(names.as_bool(a) for a in args))
        elif op == ca.OP_NOT:
            node[k] = ("not", args[0])
            kind, text = "int", f"!{names.as_bool(args[0])}"
        elif op in _UNARY:
            text = _UNARY[op].format(names.as_real(args[0]), z=literal(0.0, real))
        elif op == ca.OP_INV:
            text = f"({literal(1.0, real)}/{names.as_real(args[0])})"
        elif op in MATH:
            fn = MATH[op] + ("f" if real == "float" else "")
            text = f"{fn}({', '.join(names.as_real(a) for a in args)})"
        else:
            raise ComputationError(f"CasADi operation {op} of {f.name()} has no C translation")
        names.name[k], names.kind[k] = f"a{k}", kind
        if kind == "int":
            graph[k] = ("int", tuple(args))
        ctype = real if kind == "real" else "bool"  # <stdbool.h>: MISRA's essential Boolean
        lines.append((k, args, f"{indent}const {ctype} a{k} = {text};"))
        cur[outs[0]] = k
    terms, extra = check_terms(graph, sorted(set(needed)), blocks) if check else ([], {})
    live.update(terms)
    for k, args, _ in reversed(lines):  # drop what no output needs (-Wunused-variable)
        if k in live:
            live.update(args)
    lines = [line for line in lines if line[0] in live]
    keyed = {k: keys for k, (_, lo, hi) in blocks.items() if keys is not None
             and (names.as_real(lo), names.as_real(hi)) == tuple(keys["bounds"])}
    # a keyed saturation's v: proven finite by the key test inside, added to the sum outside
    summed = [t for t in terms if not any(blocks[k][0] == t for k in keyed
                                          if keys.get("proves", True))] if check else []
    bail = (keys or {}).get("bail")
    if bail and keyed and isinstance(keys.get("tail"), dict):
        keys["tail"].update(_tail(lines, keyed, blocks, sources, names, graph, real, indent,
                                  bound_tests, summed))
    if bail:  # the saturated branches are not printed: no addition of theirs to the sum
        extra = {k: e for k, e in extra.items() if k not in keyed}
        if not keyed:
            stores.append(f"{indent}{bail} = false;")
    if check:
        lines = _with_check(lines, summed, extra, names, real, indent,
                            {k: names.as_real(blocks[k][0]) for k in keyed})
        stores.append(f"{indent}{check} = a_sum;")
    lines = [(k, args, _saturation_text(k, *(names.as_real(a) for a in args), real, indent,
                                        bound_tests, rare, _extra_text(k, extra, summed, names),
                                        keyed.get(k) and {**keyed[k], "empty": not summed}))
             if text is None else (k, args, text) for k, args, text in lines]
    return "\n".join(_inline_logic(lines, names) + stores)


def _tail(lines, keyed, blocks, sources, names, graph, real, indent, bound_tests,
          summed) -> dict:
    """The saturated samples' continuation of a bail-mode body (:func:`c_body`): what depends
    on the keyed saturation, from the values the common path computed before it.

    ``{"frontier": [node names the continuation reads], "body": statements (the frontier as
    ``t<i>`` arguments, the sum started from ``c``, the saturation's if/else with its float
    compares), "outputs": [lvalues it sets]}``."""
    (k,) = keyed
    v = blocks[k][0]
    kind = {line[0]: names.kind.get(line[0]) for line in lines}
    down = {k}
    for j, args, _ in lines:  # in evaluation order: everything computed from the saturation
        if any(a in down for a in args):
            down.add(j)
    # computed on the common path anyway: read there by what does not depend on the
    # saturation, stored, summed, or tested (v)
    args_of = {j: args for j, args, _ in lines}
    common, stack = set(), [v, *summed, *(w for _, w in sources if w not in down)]
    while stack:  # backward from those: what the common path computes (the rest is dead there)
        a = stack.pop()
        if a not in common and a not in down:
            common.add(a)
            stack += args_of.get(a, [])
    need, frontier = set(down), []
    for j, args, _ in reversed(lines):  # decided at its own line: every reader is decided
        if j not in need:
            if not any(j in a and i in need for i, a, _ in lines):
                continue
            if j in common and kind.get(j) != "int" and graph.get(j, ("",))[0] != "const":
                frontier.append(j)  # passed on
                continue
            need.add(j)  # computed again in the continuation (read by it only, or cheap)
    frontier = sorted(set(frontier) | {v})
    body = [f"{indent}const {real} a{a} = t{i};" for i, a in enumerate(frontier)]
    body.append(f"{indent}{real} a_sum = c + a{v};  /* u before its limits: not proven here */")
    tail_lines = [(j, args, text) for j, args, text in lines
                  if (j in need and j not in frontier)]
    tail_lines = [(j, args, _saturation_text(j, *(names.as_real(a) for a in args), real, indent,
                                             bound_tests, "", f"a_sum = a_sum + a{j};"))
                  if text is None else (j, args, text) for j, args, text in tail_lines]
    stores = [f"{indent}{lv} = {names.as_real(w)};" for lv, w in sources if w in down]
    return {"frontier": [f"a{a}" for a in frontier],
            "body": "\n".join(body + _inline_logic(tail_lines, names) + stores),
            "outputs": [lv for lv, w in sources if w in down]}


#: how the finiteness test sees each operation (._finite.KINDS); comparisons are "int"
_FINITE_KIND = {ca.OP_ADD: "strict", ca.OP_SUB: "strict", ca.OP_MUL: "strict",
                ca.OP_NEG: "strict", ca.OP_SQ: "strict", ca.OP_TWICE: "strict",
                ca.OP_ASSIGN: "strict", ca.OP_FABS: "strict", ca.OP_DIV: "div",
                ca.OP_FMIN: "select", ca.OP_FMAX: "select", ca.OP_CONST: "const"}


def _sum_first(extra: dict, terms) -> bool:
    """True when the check's sum can be set before every saturation (their saturated
    branches then add to it); else each raises a flag and the sum comes last."""
    return not terms or not extra or max(terms) < min(extra)


def _extra_text(k: int, extra: dict, terms, names) -> str:
    """What the saturated branches of ``k`` do for the check: add the result to the sum (set
    before), or raise the flag ``a<k>_sat`` (added after the sum); "" for none."""
    if k not in extra:
        return ""
    if _sum_first(extra, terms):
        return f"a_sum = a_sum + a{k};"
    return f"a{k}_sat = true;"


def _with_check(lines, terms, extra, names, real, indent, keyed_v=None) -> list:
    """``lines`` with the check's sum ``a_sum`` (after its last term, or last of all when
    saturations come before it: then their flagged additions of the result, and of ``v`` for
    a keyed saturation, ``keyed_v = {k: v}``)."""
    keyed_v = keyed_v or {}
    total = " + ".join(names.as_real(t) for t in terms) or literal(0.0, real)
    text = [f"{indent}{real} a_sum = {total};"]
    at = next((i for i, line in enumerate(lines) if line[0] > max(terms, default=-1)),
              len(lines))
    if not _sum_first(extra, terms):
        at = len(lines)
        for k in extra:
            v = f"{keyed_v[k]} + " if k in keyed_v else ""
            text += [f"{indent}if (a{k}_sat) {{", f"{indent * 2}a_sum = a_sum + {v}a{k};",
                     f"{indent}}}"]
    return [*lines[:at], (-1 - at, list(terms), text), *lines[at:]]


def _inline_logic(lines, names) -> list[str]:
    """Truth values used once are written into their user: ``&&``/``||`` then short-circuit
    (e.g. the conditional-integration test is skipped when the switch is off). A block (a
    list of statements) is printed as it is."""
    uses = {}
    for _, args, _ in lines:
        for a in args:
            uses[a] = uses.get(a, 0) + 1
    text = {k: t.split(" = ", 1)[1][:-1] for k, _, t in lines if isinstance(t, str)}
    out, inlined = [], {}
    for k, args, line in lines:
        if not isinstance(line, str):
            out += line
            continue
        body = text[k]
        for a in sorted(args, reverse=True):
            if a in inlined:
                body = re.sub(rf"\ba{a}\b", lambda _m, a=a: inlined[a], body)
        if names.kind.get(k) == "int" and uses.get(k, 0) == 1:
            inlined[k] = body if body.startswith(("(", "!")) else f"({body})"
            continue
        out.append(line.split(" = ", 1)[0] + " = " + body + ";")
    return out


def _saturations(f: ca.Function) -> tuple[dict, dict]:
    """The saturations ``min(max(v, lo), hi)`` of ``f`` compared with their bounds afterwards:
    ``({k_min: (v, lo, hi)}, {k_test: (k_min, "hi" or "lo")})`` (SSA ids). The ``max`` must
    feed only the ``min``; a test is ``hi <= u`` or ``u <= lo``."""
    cur, op_of, args_of, uses = {}, {}, {}, {}
    for k in range(f.n_instructions()):
        op, ins, outs = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        args = [cur[i] for i in ins if i >= 0] if op not in (ca.OP_INPUT, ca.OP_CONST) else []
        for a in args:
            uses[a] = uses.get(a, 0) + 1
        if op != ca.OP_OUTPUT:
            op_of[k], args_of[k] = op, args
            cur[outs[0]] = k
    blocks, tests = {}, {}
    for k, op in op_of.items():
        if op != ca.OP_FMIN or op_of.get(args_of[k][0]) != ca.OP_FMAX:
            continue
        inner, hi = args_of[k]
        v, lo = args_of[inner]
        found = {j: (k, "hi" if args_of[j] == [hi, k] else "lo") for j, o in op_of.items()
                 if o == ca.OP_LE and args_of[j] in ([hi, k], [k, lo])}
        if found and uses.get(inner) == 1:
            blocks[k] = (v, lo, hi)
            tests.update(found)
    return blocks, tests


def _saturation_text(k: int, v: str, lo: str, hi: str, real: str, indent: str,
                     tests: dict, rare: str = "", extra: str = "", keys=None) -> list[str]:
    """The statements of ``a<k> = min(max(v, lo), hi)`` and its tests ``a<k>_hi = (hi <= a<k>)``,
    ``a<k>_lo = (a<k> <= lo)``: one ``if``/``else``, exact for every value (module docstring);
    ``extra``: a statement of the saturated branches (the finiteness check's, :func:`c_body`);
    ``keys``: the integer test of the unsaturated branch first (:func:`c_body`), the float
    compares behind it."""
    flags = sorted({side for (kk, side) in tests.values() if kk == k}, reverse=True)
    test = {"hi": f"({hi} <= a{k})", "lo": f"(a{k} <= {lo})"}
    i2, hint = indent * 2, (lambda c: f"({rare}({c}))" if rare else f"({c})")
    sets = [f"{i2}a{k}_{side} = {test[side]};" for side in flags]
    sets += [f"{i2}{extra}"] if extra else []
    out = [f"{indent}{real} a{k};"] + [f"{indent}bool a{k}_{side} = false;" for side in flags]
    out += [f"{indent}bool a{k}_sat = false;"] if extra.endswith("_sat = true;") else []
    out += [f"{indent}if {hint(f'!({v} > {lo})')} {{", f"{i2}a{k} = ({lo} < {hi} ? {lo} : {hi});",
            *sets, f"{indent}}} else if {hint(f'!({v} < {hi})')} {{", f"{i2}a{k} = {hi};", *sets,
            f"{indent}}} else {{", f"{i2}a{k} = {v};  /* lo < v < hi: no test holds */",
            f"{indent}}}"]
    if keys is None:
        return out
    test = (keys["test"].format(v=v) if "test" in keys
            else f"({keys['fn']}({v}) - {keys['lo1']}) >= {keys['span']}")
    if keys.get("bail"):  # the unsaturated branch only; the caller takes another path else
        return [f"{indent}const {real} a{k} = {v};  /* lo < v < hi unless {keys['bail']} */",
                *(f"{indent}const bool a{k}_{side} = false;" for side in flags),
                f"{indent}{keys['bail']} = {test};"]
    head, body = out[:out.index(next(t for t in out if t.lstrip().startswith("if ")))], None
    body = out[len(head):]
    # the sum (when the check has one) takes v where the key test does not prove it finite
    # (an empty sum is 0 and is not added to: +0 + v is not v when v is -0 for the compiler)
    add = ([f"{i2}a_sum = {'' if keys.get('empty') else 'a_sum + '}{v};"]
           if extra.startswith("a_sum") else
           [f"{i2}a{k}_sat = true;"] if extra else [])
    return [*head, f"{indent}if {hint(test)} {{  /* not lo < v < hi, or v not finite */",
            *add, *(indent + line for line in body),
            f"{indent}}} else {{", f"{i2}a{k} = {v};  /* lo < v < hi (keys): no test holds */",
            f"{indent}}}"]


def math_calls(f: ca.Function) -> list[str]:
    """The ``<math.h>`` functions :func:`c_body` prints for ``f`` (empty for the library's steps).

    Parameters
    ----------
    f : casadi.Function
        An SX function.

    Returns
    -------
    list of str

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design.codegen._emit import math_calls
    >>> x = ca.SX.sym("x")
    >>> math_calls(ca.Function("f", [x], [ca.sin(x) + ca.fmax(x, 0)]))
    ['sin']
    """
    return sorted({MATH[f.instruction_id(k)] for k in range(f.n_instructions())
                   if f.instruction_id(k) in MATH})


__all__ = ["MATH", "c_body", "literal", "math_calls"]
