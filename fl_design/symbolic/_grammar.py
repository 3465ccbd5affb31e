"""Plant expressions from text, without ``eval``: a small grammar on Python's :mod:`ast`.

A string in a config file or given to :class:`fl_design.Plant` may come from someone else, so it
is never handed to :func:`sympy.sympify` (which evaluates Python). :func:`parse_expression`
accepts only

* numbers (``int`` and finite ``float`` literals; no ``bool``, ``complex`` or strings),
* the declared names (states, input, parameters) and the constants ``pi`` and ``E`` (unless a
  declared name shadows them),
* ``+ - * / **`` and unary ``+``/``-``,
* calls of the functions in :data:`FUNCTIONS` with positional arguments,

and builds SymPy objects directly. Everything else (attributes, subscripts, lambdas,
comprehensions, keywords, other calls) is an :class:`~fl_design.errors.ExpressionError` that
names what was found and what is allowed. Limits, checked before any work: at most
:data:`MAX_LENGTH` characters, :data:`MAX_DEPTH` levels of nesting, numeric exponents of
magnitude at most :data:`MAX_EXPONENT`, exact numbers of at most :data:`MAX_DIGITS` digits.
An unknown name is reported with the declared ones and the closest match.

Examples
--------
>>> import sympy as sp
>>> from fl_design.symbolic._grammar import parse_expression
>>> x1, u = sp.symbols("x1 u", real=True)
>>> parse_expression("-2*sin(x1) + u**2/3", {"x1": x1, "u": u})
u**2/3 - 2*sin(x1)
>>> parse_expression("__import__('os')", {"x1": x1, "u": u})
Traceback (most recent call last):
...
fl_design.errors.ExpressionError: expression "__import__('os')": calls __import__, which is not an allowed function; ...
"""

from __future__ import annotations

import ast
import difflib
import math
import unicodedata
from collections.abc import Mapping

import sympy as sp

from ..errors import ExpressionError

#: Longest accepted expression string (characters).
MAX_LENGTH = 10_000
#: Deepest accepted nesting of operations and calls.
MAX_DEPTH = 100
#: Largest accepted magnitude of a numeric exponent.
MAX_EXPONENT = 1000
#: Most digits of an exact (integer or rational) number built while parsing.
MAX_DIGITS = 1000
#: Most terms an expression may have once fully expanded (``(x1 + x2 + u)**1000`` has 501,501).
MAX_TERMS = 5000
#: Highest total polynomial degree of an expression once expanded.
MAX_DEGREE = 200
#: Deepest accepted SymPy expression tree (given as a SymPy object).
MAX_TREE_DEPTH = 200

#: Function name -> (SymPy function, number of arguments).
FUNCTIONS = {
    "sin": (sp.sin, 1), "cos": (sp.cos, 1), "tan": (sp.tan, 1),
    "asin": (sp.asin, 1), "acos": (sp.acos, 1), "atan": (sp.atan, 1), "atan2": (sp.atan2, 2),
    "sinh": (sp.sinh, 1), "cosh": (sp.cosh, 1), "tanh": (sp.tanh, 1),
    "asinh": (sp.asinh, 1), "acosh": (sp.acosh, 1), "atanh": (sp.atanh, 1),
    "exp": (sp.exp, 1), "log": (sp.log, 1), "sqrt": (sp.sqrt, 1), "erf": (sp.erf, 1),
    "Abs": (sp.Abs, 1), "abs": (sp.Abs, 1), "sign": (sp.sign, 1),
    "Min": (sp.Min, 2), "Max": (sp.Max, 2), "min": (sp.Min, 2), "max": (sp.Max, 2),
}
#: Constants available unless a declared name shadows them.
CONSTANTS = {"pi": sp.pi, "E": sp.E}

_BINARY = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b,
           ast.Mult: lambda a, b: a * b, ast.Div: lambda a, b: a / b}
_SYMBOLS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**",
            ast.FloorDiv: "//", ast.Mod: "%", ast.MatMult: "@", ast.BitXor: "^",
            ast.BitAnd: "&", ast.BitOr: "|", ast.LShift: "<<", ast.RShift: ">>"}


def _group(node: ast.AST) -> str | None:
    """Operators that chain without nesting: ``+ -`` and ``* /``."""
    if isinstance(node, ast.BinOp):
        if isinstance(node.op, (ast.Add, ast.Sub)):
            return "sum"
        if isinstance(node.op, (ast.Mult, ast.Div)):
            return "product"
    return None


def _short(text: str, limit: int = 60) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


class _Builder:
    """One expression: checks the tree's depth, then builds SymPy objects node by node."""

    def __init__(self, text: str, names: Mapping[str, sp.Basic], what: str):
        self.text, self.names, self.what = text, dict(names), what

    def fail(self, message: str) -> ExpressionError:
        return ExpressionError(f"{self.what} {_short(self.text)!r}: {message}")

    def allowed(self) -> str:
        return (f"declared names {sorted(self.names) or '(none)'}, numbers, + - * / **, and the "
                f"functions {', '.join(sorted(FUNCTIONS))}")

    def check_depth(self, tree: ast.AST) -> None:
        """Refuse nesting above MAX_DEPTH; a chain ``a + b - c + ...`` counts as one level."""
        stack = [(tree, 0)]
        while stack:  # iterative: a deep tree cannot overflow Python's stack here
            node, depth = stack.pop()
            if depth > MAX_DEPTH:
                raise self.fail(f"nested more than {MAX_DEPTH} levels deep; split it into "
                                "simpler terms")
            for child in ast.iter_child_nodes(node):
                same = child is getattr(node, "left", None) and _group(child) is not None \
                    and _group(child) == _group(node)
                stack.append((child, depth if same else depth + 1))

    def build(self, node: ast.AST) -> sp.Expr:
        method = getattr(self, f"_{type(node).__name__}", None)
        if method is None:
            raise self.fail(f"{self.describe(node)} is not allowed; use only {self.allowed()}")
        return method(node)

    @staticmethod
    def describe(node: ast.AST) -> str:
        kinds = {ast.Attribute: "attribute access", ast.Subscript: "a subscript",
                 ast.Lambda: "a lambda", ast.ListComp: "a comprehension",
                 ast.GeneratorExp: "a comprehension", ast.Compare: "a comparison",
                 ast.BoolOp: "a boolean operation", ast.IfExp: "a conditional expression",
                 ast.NamedExpr: "an assignment", ast.JoinedStr: "an f-string"}
        return kinds.get(type(node), f"a {type(node).__name__} node")

    def _Expression(self, node: ast.Expression) -> sp.Expr:
        return self.build(node.body)

    def _Constant(self, node: ast.Constant) -> sp.Expr:
        v = node.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(f"the literal {v!r} is not a real number")
        if isinstance(v, float):
            if not math.isfinite(v):
                raise self.fail(f"the number {v!r} is not finite (overflows a double)")
            return sp.Float(v)
        return self._exact(sp.Integer(v))

    def _exact(self, value: sp.Expr) -> sp.Expr:
        if isinstance(value, sp.Rational):
            digits = max(len(str(abs(value.p))), len(str(value.q)))
            if digits > MAX_DIGITS:
                raise self.fail(f"an exact number with {digits} digits exceeds the limit of "
                                f"{MAX_DIGITS}; write it as a float (e.g. 1e300)")
        return value

    def _Name(self, node: ast.Name) -> sp.Expr:
        if node.id in self.names:
            return self.names[node.id]
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        if node.id in FUNCTIONS:
            raise self.fail(f"the function {node.id} is used without arguments")
        close = difflib.get_close_matches(node.id, list(self.names), n=1, cutoff=0.5)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise self.fail(f"unknown symbol {node.id!r}{hint}; the declared names are "
                        f"{sorted(self.names)} (declare a parameter in params)")

    def _UnaryOp(self, node: ast.UnaryOp) -> sp.Expr:
        if isinstance(node.op, ast.USub):
            return self._exact(-self.build(node.operand))
        if isinstance(node.op, ast.UAdd):
            return self.build(node.operand)
        raise self.fail(f"the unary operator {type(node.op).__name__} is not allowed; "
                        "use only unary + and -")

    def _BinOp(self, node: ast.BinOp) -> sp.Expr:
        chain = [node]  # a left-leaning chain a + b - c ... is folded in a loop, not recursion
        while _group(chain[-1]) is not None and _group(chain[-1].left) == _group(chain[-1]):
            chain.append(chain[-1].left)
        value = self.build(chain[-1].left)
        for link in reversed(chain):
            right = self.build(link.right)
            if isinstance(link.op, ast.Pow):
                value = self._power(value, right)
                continue
            op = _BINARY.get(type(link.op))
            if op is None:
                raise self.fail(f"the operator {_SYMBOLS.get(type(link.op), type(link.op).__name__)}"
                                " is not allowed; use + - * / ** (and ** for powers, not ^)")
            value = self._exact(op(value, right))
        return value

    def _power(self, base: sp.Expr, exponent: sp.Expr) -> sp.Expr:
        if exponent.is_number:
            try:
                size = abs(complex(exponent))
            except (TypeError, ValueError):
                size = math.inf
            if not size <= MAX_EXPONENT:
                raise self.fail(f"the exponent {_short(str(exponent), 30)} exceeds the limit of "
                                f"{MAX_EXPONENT} in magnitude")
            if isinstance(base, sp.Rational) and isinstance(exponent, sp.Rational):
                digits = math.log10(max(abs(base.p), base.q, 1)) * abs(float(exponent))
                if digits > MAX_DIGITS:
                    raise self.fail(f"{_short(str(base), 20)}**{exponent} has about {digits:.0f} digits, above "
                                    f"the limit of {MAX_DIGITS}; write it as a float")
        return self._exact(base ** exponent)

    def _Call(self, node: ast.Call) -> sp.Expr:
        name = node.func.id if isinstance(node.func, ast.Name) else None
        if name is None or name not in FUNCTIONS:
            shown = name or _short(ast.unparse(node.func), 40)
            raise self.fail(f"calls {shown}, which is not an allowed function; the functions "
                            f"are {', '.join(sorted(FUNCTIONS))}")
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            raise self.fail(f"{name}(...) takes positional arguments only")
        fn, arity = FUNCTIONS[name]
        if len(node.args) != arity:
            raise self.fail(f"{name} takes {arity} argument(s), got {len(node.args)}")
        return fn(*(self.build(a) for a in node.args))


def parse_expression(text: str, names: Mapping[str, sp.Basic], *,
                     what: str = "expression") -> sp.Expr:
    """The SymPy expression written in ``text``, built without evaluating any Python.

    Parameters
    ----------
    text : str
        The expression, e.g. ``"-k*sin(x1) + u"``.
    names : mapping of str to sympy.Symbol
        The declared names (states, input, parameters) and the symbols they stand for.
    what : str, optional
        Where the text comes from, for messages (``"rhs[1]"``).

    Returns
    -------
    sympy.Expr

    Raises
    ------
    ExpressionError
        ``text`` is not a string, too long, not valid syntax, nested too deep, uses a name or
        a construct outside the grammar, or an exponent or exact number above the limits.

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._grammar import parse_expression
    >>> a1 = sp.Symbol("A1")
    >>> parse_expression("Al*2", {"A1": a1}, what="rhs[0]")
    Traceback (most recent call last):
    ...
    fl_design.errors.ExpressionError: rhs[0] 'Al*2': unknown symbol 'Al' (did you mean 'A1'?); the declared names are ['A1'] ...
    """
    names = check_names(names, what=what)
    builder = _Builder(str(text) if isinstance(text, str) else "", names, what)
    if not isinstance(text, str):
        raise ExpressionError(f"{what} must be a string, got {type(text).__name__} {text!r:.60}")
    if len(text) > MAX_LENGTH:
        raise builder.fail(f"{len(text)} characters, above the limit of {MAX_LENGTH}")
    if not text.strip():
        raise builder.fail("empty expression")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as err:
        raise builder.fail(f"not a valid expression ({err.msg}"
                           f"{f' at column {err.offset}' if err.offset else ''})") from None
    except (RecursionError, MemoryError, ValueError) as err:
        raise builder.fail(f"too complex for Python's parser ({type(err).__name__}); split it "
                           "into simpler terms") from None
    builder.check_depth(tree)
    try:
        out = builder.build(tree)
    except RecursionError:  # cannot happen below MAX_DEPTH, kept as a clear message
        raise builder.fail(f"nested too deeply (limit {MAX_DEPTH})") from None
    if not isinstance(out, sp.Expr):
        raise builder.fail(f"does not give a scalar expression (got {type(out).__name__})")
    return check_size(out, f"{what} {_short(text)!r}")


def check_names(names, *, what: str = "the declared names"):
    """``names`` after refusing two that Python reads as one, or one that is a function.

    Python reads identifiers in NFKC form (``ℎ``, the Planck-constant letter, is ``h``), so two
    declared names equal after NFKC normalization would silently stand for one symbol: refused.
    A name of the grammar's functions (``sin``) is refused too.

    Parameters
    ----------
    names : mapping of str to object, or iterable of str
        The declared names (a mapping is returned keyed by the normalized names).
    what : str, optional
        Where the names come from, for messages.

    Returns
    -------
    dict or list
        The names, NFKC-normalized (a dict for a mapping, else a list).

    Raises
    ------
    ExpressionError
        Two names collide after normalization, a name is not a string or not an identifier,
        or a name is one of :data:`FUNCTIONS`.

    Examples
    --------
    >>> from fl_design.symbolic._grammar import check_names
    >>> check_names(["x1", "u"])
    ['x1', 'u']
    >>> check_names(["h", "\u210e"])
    Traceback (most recent call last):
    ...
    fl_design.errors.ExpressionError: the declared names: 'h' and '\u210e' are the same name once Unicode-normalized (NFKC: 'h')...
    """
    items = list(names.items()) if isinstance(names, Mapping) else [(n, None) for n in names]
    seen: dict[str, str] = {}
    out = []
    for name, value in items:
        if not isinstance(name, str) or not name.isidentifier():
            raise ExpressionError(f"{what}: the name {name!r} is not an identifier (letters, "
                                  "digits and underscores, not starting with a digit)")
        norm = unicodedata.normalize("NFKC", name)
        if norm in seen:
            raise ExpressionError(
                f"{what}: {seen[norm]!r} and {name!r} are the same name once Unicode-normalized "
                f"(NFKC: {norm!r}), as Python reads them; give them different names")
        if norm in FUNCTIONS:
            raise ExpressionError(f"{what}: the name {name!r} is a function of the expression "
                                  f"grammar ({', '.join(sorted(FUNCTIONS))}); rename it")
        seen[norm] = name
        out.append((norm, value))
    return dict(out) if isinstance(names, Mapping) else [n for n, _ in out]


#: Most exponentials nested in one another (``exp``, ``sinh``, ``cosh``, a power with a
#: variable exponent): ``exp(exp(exp(exp(exp(x)))))`` at a point is a number of millions of
#: digits whose evaluation SymPy cannot interrupt (it hung ``derive``).
MAX_EXP_NESTING = 3
_GROWTH = (sp.exp, sp.sinh, sp.cosh)


def _grows(node: sp.Basic) -> bool:
    return isinstance(node, _GROWTH) or (isinstance(node, sp.Pow) and not node.exp.is_number)


def _walk_size(expr: sp.Basic) -> tuple[int, int, int]:
    """``(terms, degree, depth)``: the most terms and highest degree of any part of ``expr``
    once expanded (inside function arguments too: ``expand`` goes there), and the tree's depth;
    bottom-up without recursion, saturating above the limits. Exponentials nested more than
    :data:`MAX_EXP_NESTING` deep are refused here (:class:`ExpressionError`)."""
    cap = 10 * MAX_TERMS
    done: dict = {}
    growth: dict = {}
    stack = [(expr, 0, False)]
    deepest = worst_terms = worst_degree = 0
    while stack:
        node, depth, ready = stack.pop()
        deepest = max(deepest, depth)
        if depth > MAX_TREE_DEPTH:
            return 0, 0, depth
        if node in done:
            continue
        if not ready:
            stack.append((node, depth, True))
            stack.extend((a, depth + 1, False) for a in node.args if a not in done)
            continue
        kids = [done[a] for a in node.args]
        if isinstance(node, sp.Add):
            terms, degree = min(cap, sum(k[0] for k in kids)), max(k[1] for k in kids)
        elif isinstance(node, sp.Mul):
            terms, degree = 1, 0
            for k in kids:
                terms, degree = min(cap, terms * k[0]), min(cap, degree + k[1])
        elif isinstance(node, sp.Pow) and node.exp.is_Integer and node.exp > 0:
            n, (k, d) = int(node.exp), kids[0]
            terms = cap if k > 1 and n > cap else min(cap, math.comb(n + k - 1, k - 1))
            degree = min(cap, n * d)
        elif isinstance(node, sp.Symbol):
            terms, degree = 1, 1
        else:  # numbers, functions, other powers: one term after expansion
            terms, degree = 1, 0
        done[node] = (terms, degree)
        worst_terms, worst_degree = max(worst_terms, terms), max(worst_degree, degree)
        growth[node] = max((growth[a] for a in node.args), default=0) + _grows(node)
        if growth[node] > MAX_EXP_NESTING:
            raise ExpressionError(
                f"exponentials nested more than {MAX_EXP_NESTING} deep ({_short(str(node))}; limit "
                f"MAX_EXP_NESTING = {MAX_EXP_NESTING}): its values overflow every number "
                "format and cannot be evaluated in bounded time; write it with fewer nested "
                "exp/sinh/cosh/powers")
    return worst_terms, worst_degree, deepest


def check_size(expr: sp.Basic, what: str = "expression") -> sp.Basic:
    """``expr`` if its expanded size stays within bounds, checked before anything expands it.

    The derivation expands and differentiates: ``(x1 + x2 + u)**1000`` (25 characters) has
    501,501 terms once expanded and kept ``derive`` busy for minutes. Refused when any part of
    ``expr`` expands to more than :data:`MAX_TERMS` terms or a total degree above
    :data:`MAX_DEGREE`, or when the tree is deeper than :data:`MAX_TREE_DEPTH`.

    Parameters
    ----------
    expr : sympy.Basic
    what : str, optional
        For messages.

    Returns
    -------
    sympy.Basic

    Raises
    ------
    ExpressionError

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._grammar import check_size
    >>> x1, x2, u = sp.symbols("x1 x2 u")
    >>> check_size((x1 + u)**3)
    (u + x1)**3
    >>> check_size((x1 + x2 + u)**1000 - x1)
    Traceback (most recent call last):
    ...
    fl_design.errors.ExpressionError: expression: expands to more than 5000 terms (limit MAX_TERMS = 5000)...
    """
    if not isinstance(expr, sp.Basic):
        return expr
    try:
        terms, degree, depth = _walk_size(expr)
    except ExpressionError as exc:
        raise ExpressionError(f"{what}: {exc}") from None
    if depth > MAX_TREE_DEPTH:
        raise ExpressionError(f"{what}: the expression tree is more than {MAX_TREE_DEPTH} "
                              "levels deep; build it from simpler terms")
    if terms > MAX_TERMS:
        shown = f"more than {MAX_TERMS}" if terms >= 10 * MAX_TERMS else f"{terms}"
        raise ExpressionError(
            f"{what}: expands to {shown} terms (limit MAX_TERMS = {MAX_TERMS}), which the "
            "derivation (Lie derivatives, expansion) cannot handle in reasonable time; write "
            "it with fewer terms or a lower power")
    if degree > MAX_DEGREE:
        raise ExpressionError(f"{what}: has polynomial degree {degree} once expanded (limit "
                              f"{MAX_DEGREE}); write it with a lower power")
    return expr


__all__ = ["CONSTANTS", "FUNCTIONS", "MAX_DEGREE", "MAX_DEPTH", "MAX_DIGITS", "MAX_EXPONENT",
           "MAX_EXP_NESTING", "MAX_LENGTH", "MAX_TERMS", "MAX_TREE_DEPTH", "check_names", "check_size",
           "parse_expression"]
