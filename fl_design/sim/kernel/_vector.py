"""The lanes kernel's C in explicit vectors: one statement per vector of ``FL_V`` doubles.

The lane emitter (:mod:`fl_design.sim.kernel._emit`) prints every instruction of the step as
one statement on a GCC/Clang vector type ``fl_v`` (``vector_size``: the vector extensions
both compilers share), not as a scalar statement inside an auto-vectorised loop: the
compiler cannot give up vectorising it (GCC 12 did, on the TRMS step in two lane groups: a
mask of masks it could not vectorise, scalar code 3-6x slower), so any number of lane groups
can be interleaved. Comparisons give lane masks (all bits set or clear), selects and the
``c ? 1.0 : 0.0`` of CasADi's printed code are bit operations on them, so every lane computes
what the scalar kernel computes, bit for bit: ``+ - * /`` are the same IEEE operations (no
contraction), ``fabs`` clears the sign bit, ``fmin``/``fmax`` keep glibc's x86-64 choice. Math
functions are libmvec's vector functions called by their vector-ABI names (``_ZGVdN4v_tanh``
for AVX2...) when asked for and present, else the scalar ``<math.h>`` function lane by lane.

Examples
--------
>>> from fl_design.sim.kernel._vector import prelude
>>> "_ZGVdN4v_tanh" in prelude(4, ("tanh",), "d", {"tanh"})
True
>>> "_ZGV" in prelude(4, (), "d", {"tanh"})
False
"""

from __future__ import annotations

import casadi as ca

#: Binary operations (``{0}``, ``{1}``: vector operands) as CasADi prints them, on vectors.
BINARY = {ca.OP_ADD: "({0}+{1})", ca.OP_SUB: "({0}-{1})", ca.OP_MUL: "({0}*{1})",
          ca.OP_DIV: "({0}/{1})", ca.OP_LT: "FL_B({0}<{1})", ca.OP_LE: "FL_B({0}<={1})",
          ca.OP_EQ: "FL_B({0}=={1})", ca.OP_NE: "FL_B({0}!={1})",
          ca.OP_AND: "FL_B(({0}!=FL_Z) & ({1}!=FL_Z))",
          ca.OP_OR: "FL_B(({0}!=FL_Z) | ({1}!=FL_Z))",
          ca.OP_IF_ELSE_ZERO: "FL_AND({0}!=FL_Z, {1})",
          ca.OP_FMIN: "FL_SEL(({0}<{1}) | ({1}!={1}), {0}, {1})",
          ca.OP_FMAX: "FL_SEL(({0}>{1}) | ({1}!={1}), {0}, {1})",
          ca.OP_POW: "fl_pow({0},{1})", ca.OP_CONSTPOW: "fl_pow({0},{1})",
          ca.OP_ATAN2: "fl_atan2({0},{1})", ca.OP_COPYSIGN: "fl_copysign({0},{1})",
          ca.OP_FMOD: "fl_fmod({0},{1})", ca.OP_HYPOT: "fl_hypot({0},{1})"}
#: Unary operations on vectors.
UNARY = {ca.OP_NEG: "(-{0})", ca.OP_SQ: "({0}*{0})", ca.OP_TWICE: "(FL_C(2.)*{0})",
         ca.OP_INV: "(FL_C(1.)/{0})", ca.OP_NOT: "FL_B({0}==FL_Z)",
         ca.OP_SIGN: "FL_SEL({0}<FL_Z, FL_C(-1.0), FL_SEL({0}>FL_Z, FL_C(1.0), {0}))",
         ca.OP_ASSIGN: "{0}"}
#: Two-argument ``<math.h>`` functions (always lane by lane).
BINARY_MATH = ("pow", "atan2", "copysign", "fmod", "hypot")


def select(cond: str, a: str, b: str) -> str:
    """``cond != 0 ? a + 0.0 : 0.0 + b`` on vectors (CasADi's ``if_else`` as one select)."""
    return f"FL_SEL({cond}!=FL_Z, ({a}+FL_Z), (FL_Z+{b}))"


def constant(text: str) -> str:
    """A C double constant broadcast to every lane."""
    return f"FL_C({text})"


def load(ref: str) -> str:
    """The vector at the array element ``ref`` (``A[i * FL_W + l]``: aligned, FL_V doubles)."""
    return f"FL_LD(&{ref})"


def store(ref: str, value: str) -> str:
    """The statement storing vector ``value`` at the array element ``ref``."""
    return f"FL_ST(&{ref}, {value});"


def prelude(width: int, vector_math: tuple[str, ...], variant: str | None,
            used: set[str]) -> str:
    """Types, macros and math functions the vector statements use.

    Parameters
    ----------
    width : int
        Doubles per vector (``FL_V``).
    vector_math : tuple of str
        Functions to take from libmvec (its vector versions exist for this level).
    variant : str or None
        libmvec's ISA letter (``b``, ``d``, ``e``, ``n``).
    used : set of str
        ``<math.h>`` names the statements call (``fl_<name>``).

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.sim.kernel._vector import prelude
    >>> "fl_floor" in prelude(2, (), None, {"floor"})
    True
    """
    lanes = ", ".join(["x"] * width)
    out = [f"typedef double fl_v __attribute__((vector_size({8 * width})));",
           f"typedef double fl_va __attribute__((vector_size({8 * width}), may_alias));",
           "typedef __typeof__((fl_v){0} < (fl_v){0}) fl_m;  /* lane masks: all bits or none */",
           "#define FL_LD(p) (*(const fl_va*)(p))",
           "#define FL_ST(p, x) (*(fl_va*)(p) = (x))",
           f"#define FL_C(x) ((fl_v){{{lanes}}})",
           "#define FL_Z FL_C(0.0)",
           "#define FL_SEL(m, a, b) ((fl_v)(((m) & (fl_m)(a)) | (~(m) & (fl_m)(b))))",
           "#define FL_AND(m, a) ((fl_v)((m) & (fl_m)(a)))",
           "#define FL_B(m) FL_AND(m, FL_C(1.0))",
           "#define FL_M(x) ((fl_m)(x))  /* a mask kept in a vector's bits */"]
    pcs = "\n#ifdef __aarch64__\n__attribute__((aarch64_vector_pcs))\n#endif\n"
    for name in sorted(used):
        if name == "fabs":
            out.append("static inline fl_v fl_fabs(fl_v x) "
                       "{ return (fl_v)(~(fl_m)FL_C(-0.0) & (fl_m)x); }")
        elif name in vector_math and variant:
            mangled = f"_ZGV{variant}N{width}v_{name}"
            # const: a pure function of its argument, so GCC merges calls on equal arguments
            # (the TRMS step computes tanh(1000 x2) twice: RK4 stage 1 and the true sigma)
            out.append(f"{pcs}fl_v {mangled}(fl_v) __attribute__((const));\n"
                       f"#define fl_{name} {mangled}")
        elif name in BINARY_MATH:
            out.append(f"static inline fl_v fl_{name}(fl_v x, fl_v y) {{ fl_v r; int i; "
                       f"for (i = 0; i < {width}; ++i) r[i] = {name}(x[i], y[i]); return r; }}")
        else:
            out.append(f"static inline fl_v fl_{name}(fl_v x) {{ fl_v r; int i; "
                       f"for (i = 0; i < {width}; ++i) r[i] = {name}(x[i]); return r; }}")
    return "\n".join(out) + "\n"


__all__ = ["BINARY", "BINARY_MATH", "UNARY", "constant", "load", "prelude", "select", "store"]
