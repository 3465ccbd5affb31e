"""A hand-written C step of an EHGO design (delta realization), the reference of bench_codegen.

What an engineer would write for the paper's loop: the design's numbers as literals, the
observer in its delta form ``g = G (xi - e_1 y)``, ``xhat = D^-1 (xi + theta g)``, the clamps,
the integrator, ``v``, the saturated dynamic law; no checks. ``hand_source(design, real)``
returns the C (``hand_step(hand_t *s, real y, real r)``); the bench checks that it computes
``Design.step`` before comparing costs.

``compare_with_hand(pkg, folder)`` builds a driver linking the package's ``<prefix>_step`` and
``hand_step`` (separate objects, ``-O2``, both called out of line), checks that both compute
``Design.step`` (from the design's own start, 2000 samples), times them (best of three runs)
and counts their instructions under ``valgrind --tool=callgrind`` (inclusive, per call).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np

from fl_design.design import EHGO


def _lit(x: float, real: str) -> str:
    text = repr(float(x)) + ("f" if real == "float" else "")
    return f"({text})" if text.startswith("-") else text


def hand_source(design, real: str) -> str:
    """C source of ``hand_step`` for ``design`` (EHGO, any rho) in ``real`` precision."""
    est, ctrl = design.estimator, design.controller
    est = est.replace(realization="delta") if isinstance(est, EHGO) else est
    n, rho = est.state_size, design.rho
    G, dinv = est.delta_matrix, np.asarray(est.unscaling, dtype=float)
    theta = 0.5 if est.method == "bilinear" else (1.0 if est.method == "backward_euler" else 0.0)
    L = lambda x: _lit(x, real)
    out = [f"typedef struct {{ {real} xi[{n}]; {real} u; {real} z; }} hand_t;",
           f"{real} hand_step(hand_t *s, {real} y, {real} r);",
           f"{real} hand_step(hand_t *s, {real} y, {real} r) {{",
           f"  const {real} e0 = s->xi[0] - y;"]
    e = ["e0"] + [f"s->xi[{j}]" for j in range(1, n)]
    for i in range(n):
        terms = " + ".join(f"{L(G[i, j])} * {e[j]}" for j in range(n))
        out.append(f"  const {real} g{i} = {terms};")
    for i in range(n):
        out.append(f"  {real} h{i} = {L(dinv[i])} * (s->xi[{i}] + {L(theta)} * g{i});")
    for i, lim in enumerate(ctrl.estimate_ranges):
        if lim is not None:
            out.append(f"  h{i} = h{i} < {L(lim[0])} ? {L(lim[0])} : "
                       f"(h{i} > {L(lim[1])} ? {L(lim[1])} : h{i});")
    out.append(f"  const {real} err = h0 - r;")
    out.append(f"  const {real} z = s->z + {L(design.T)} * err;")
    v = f"-{L(ctrl.gains[0])} * err - {L(ctrl.ki)} * z"
    v += "".join(f" - {L(ctrl.gains[i])} * h{i}" for i in range(1, rho))
    out.append(f"  {real} u = s->u + {L(ctrl.gamma)} * ({v} - h{rho});")
    if ctrl.u_range is not None:
        lo, hi = ctrl.u_range
        out.append(f"  u = u < {L(lo)} ? {L(lo)} : (u > {L(hi)} ? {L(hi)} : u);")
    out += [f"  s->xi[{i}] += g{i};" for i in range(n)]
    out += ["  s->u = u;", "  s->z = z;", "  return u;", "}"]
    return "\n".join(out) + "\n"


DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "@P@.h"
typedef struct { @R@ xi[@N@]; @R@ u; @R@ z; } hand_t;
@R@ hand_step(hand_t *s, @R@ y, @R@ r);
static @R@ table[1024];
static const @R@ start[@S@] = {@START@};
static double now(void) { return (double) clock() / (double) CLOCKS_PER_SEC; }
int main(int argc, char **argv) {
  long n = atol(argv[2]), k;
  @P@_state_t s;
  hand_t h;
  volatile @R@ sink = 0;
  for (k = 0; k < 1024; ++k) table[k] = (@R@) (0.3 * (1.0 - (double) (k < 512 ? k : 1024 - k) / 512.0));
  @P@_init(&s);
  memcpy(h.xi, start, sizeof h.xi); h.u = start[@N@]; h.z = start[@N@ + 1];
  if (strcmp(argv[1], "check") == 0) {
    for (k = 0; k < n; ++k) printf("%.17g %.17g\n", (double) @P@_step(&s, table[k & 1023], (@R@) 0.3),
                                   (double) hand_step(&h, table[k & 1023], (@R@) 0.3));
    return 0;
  }
  if (strcmp(argv[1], "time") == 0) {
    double t0 = now(), t1, t2;
    for (k = 0; k < n; ++k) sink = sink + @P@_step(&s, table[k & 1023], (@R@) 0.3);
    t1 = now();
    for (k = 0; k < n; ++k) sink = sink + hand_step(&h, table[k & 1023], (@R@) 0.3);
    t2 = now();
    printf("%.6g %.6g\n", 1e9 * (t1 - t0) / (double) n, 1e9 * (t2 - t1) / (double) n);
    return 0;
  }
  for (k = 0; k < n; ++k) sink = sink + @P@_step(&s, table[k & 1023], (@R@) 0.3);
  for (k = 0; k < n; ++k) sink = sink + hand_step(&h, table[k & 1023], (@R@) 0.3);
  return sink > 1e30 ? 1 : 0;
}
"""


def _ir(out_file: Path, function: str) -> int:
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", str(out_file)],
                          capture_output=True, text=True, check=True, timeout=120).stdout
    for line in text.splitlines():
        if re.search(rf"[:\s]{function}\b", line) and not line.strip().startswith("--"):
            return int(line.split()[0].replace(",", ""))
    raise RuntimeError(f"{function} not in the callgrind profile")


def compare_with_hand(pkg, folder: Path, *, steps: int = 5_000_000) -> dict:
    """``{"max_diff", "ns_generated", "ns_hand", "ir_generated", "ir_hand"}`` (see module)."""
    folder.mkdir(parents=True, exist_ok=True)
    real, p, used = pkg.precision, pkg.prefix, pkg.step_design
    (folder / "hand.c").write_text(hand_source(pkg.design, real))
    start = used.initial_state()
    subs = {"@P@": p, "@R@": real, "@N@": str(used.estimator.state_size),
            "@S@": str(start.size), "@START@": ", ".join(repr(float(v)) for v in start)}
    text = DRIVER
    for k, v in subs.items():
        text = text.replace(k, v)
    (folder / "count.c").write_text(text)
    exe = folder / "count"
    subprocess.run(["cc", "-O2", "-std=c99", f"-I{pkg.out_dir}", "-o", str(exe),
                    str(folder / "count.c"), str(folder / "hand.c"), *map(str, pkg.sources)],
                   check=True, timeout=120)
    run = lambda *a: subprocess.run([str(exe), *a], capture_output=True, text=True, check=True,
                                    timeout=600).stdout
    u = np.array(run("check", "2000").split(), dtype=float).reshape(-1, 2)
    u_ref = used.run(np.array([float(np.float32(0.3 * (1 - min(k % 1024, 1024 - k % 1024) / 512)))
                               if real == "float" else 0.3 * (1 - min(k % 1024, 1024 - k % 1024) / 512)
                               for k in range(2000)]), 0.3).u
    out = {"max_diff_generated": float(np.max(np.abs(u[:, 0] - u_ref)) / np.max(np.abs(u_ref))),
           "max_diff_hand": float(np.max(np.abs(u[:, 1] - u_ref)) / np.max(np.abs(u_ref)))}
    times = np.array([run("time", str(steps)).split() for _ in range(3)], dtype=float)
    out["ns_generated"], out["ns_hand"] = (float(v) for v in times.min(axis=0))
    if shutil.which("valgrind") and shutil.which("callgrind_annotate"):
        n = 20_000
        prof = folder / "callgrind.out"
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={prof}", str(exe),
                        "count", str(n)], capture_output=True, check=True, timeout=600)
        out["ir_generated"] = _ir(prof, f"{p}_step") / n
        out["ir_hand"] = _ir(prof, "hand_step") / n
    return out
