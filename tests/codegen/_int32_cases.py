"""Shared by the Q31 tests: C functions ``int32_t f<i>(int32_t a, int32_t b)`` built with the
Q31 template's own helpers under UBSan, fed ``"i a b"`` lines, their outputs read back."""

from __future__ import annotations

import re
import subprocess
from importlib import resources

from fl_design._toolchain import find_compiler


def template_helpers(*names: str) -> str:
    """The ``static ... fl_<name>(...)`` helpers of ``step_q31.c.in``, prefix ``fl``."""
    template = (resources.files("fl_design.codegen") / "templates" / "step_q31.c.in").read_text()
    found = "".join(re.search(rf"static [^\n]*@PREFIX@_{name}\(.*?\n}}\n", template,
                              re.DOTALL).group(0) for name in names)
    return found.replace("@PREFIX@", "fl").replace("@P@_INLINE", "inline")


def run_int32_cases(tmp_path, name: str, helpers: str, funcs: list[str],
                    lines: list[str]) -> list[int]:
    """Compile ``funcs`` (``f0``, ``f1``, ...) after ``helpers`` with ``-fsanitize=undefined``
    (any undefined behaviour aborts), run every ``"i a b"`` line through ``f<i>(a, b)`` and
    return the outputs."""
    calls = "\n".join(f"    case {i}: out = f{i}(a, b); break;" for i in range(len(funcs)))
    src = tmp_path / f"{name}.c"
    src.write_text("#include <stdint.h>\n#include <stdio.h>\n#include <stdbool.h>\n" + helpers
                   + "\n".join(funcs) + "\nint main(void) {\n  int i; long a_, b_;\n"
                   "  while (scanf(\"%d %ld %ld\", &i, &a_, &b_) == 3) {\n"
                   "    const int32_t a = (int32_t) a_, b = (int32_t) b_; int32_t out = 0;\n"
                   f"    switch (i) {{\n{calls}\n    default: break;\n    }}\n"
                   "    printf(\"%ld\\n\", (long) out);\n  }\n  return 0;\n}\n")
    exe = tmp_path / name
    subprocess.run([find_compiler(), "-O2", "-std=c99", "-Wall", "-Wextra", "-Werror",
                    "-fsanitize=undefined", "-fno-sanitize-recover=all", str(src), "-o",
                    str(exe)], check=True, timeout=120)
    out = subprocess.run([str(exe)], input="\n".join(lines) + "\n", capture_output=True,
                         text=True, check=True, timeout=60).stdout.split()
    return [int(v) for v in out]
