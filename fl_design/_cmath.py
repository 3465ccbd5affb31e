"""CasADi's elementary operations and their C99 ``<math.h>`` names (both C emitters use it).

The compiled kernel (:mod:`fl_design.sim.kernel._emit`) and the exported step
(:mod:`fl_design.codegen._emit`) print these calls by name; each adds what it treats its own
way (``fabs``, ``pow``, ``atan2``: a call in the kernel, inline or ``f``-suffixed in the
package).

Examples
--------
>>> import casadi as ca
>>> from fl_design._cmath import ELEMENTARY
>>> ELEMENTARY[ca.OP_SIN], ca.OP_FABS in ELEMENTARY
('sin', False)
"""

from __future__ import annotations

import casadi as ca

#: One-argument elementary functions of C99 ``<math.h>`` by CasADi operation code.
ELEMENTARY = {ca.OP_EXP: "exp", ca.OP_LOG: "log", ca.OP_SQRT: "sqrt", ca.OP_SIN: "sin",
              ca.OP_COS: "cos", ca.OP_TAN: "tan", ca.OP_ASIN: "asin", ca.OP_ACOS: "acos",
              ca.OP_ATAN: "atan", ca.OP_FLOOR: "floor", ca.OP_CEIL: "ceil", ca.OP_ERF: "erf",
              ca.OP_SINH: "sinh", ca.OP_COSH: "cosh", ca.OP_TANH: "tanh",
              ca.OP_ASINH: "asinh", ca.OP_ACOSH: "acosh", ca.OP_ATANH: "atanh",
              ca.OP_LOG1P: "log1p", ca.OP_EXPM1: "expm1"}

__all__ = ["ELEMENTARY"]
