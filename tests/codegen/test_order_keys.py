"""The float step's common-path test of u within its limits, on order keys of bit patterns.

``PREFIX_derive`` turns the validated limits into ``u_key`` and the step takes its common path
when ``PREFIX_key(v) - u_key[0] < u_key[1]`` (unsigned). Compiled from the package's own source
(included, so its static functions are reached) and fed every pair of a set of limits (zeros
of both signs, subnormals, the extremes, crossed and equal limits) with special and random
values, the test must say exactly what IEEE single precision's ``lo < v < hi`` says (NumPy's
float32 compare, independent of the C), false for every NaN and infinity.
"""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.codegen import generate_c

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")

PROBE = r"""#include <stdio.h>
#include <string.h>
#include "fl.c"
static float from_bits(uint32_t b) { float v; memcpy(&v, &b, sizeof v); return v; }
int main(void) {
  fl_state_t s;
  unsigned lo, hi, v;
  fl_init(&s);
  while (scanf("%x %x %x", &lo, &hi, &v) == 3) {
    s.p.u_min = from_bits(lo);
    s.p.u_max = from_bits(hi);
    fl_derive(&s);
    printf("%d\n", (fl_key(from_bits(v)) - s.u_key[0]) < s.u_key[1]);
  }
  return 0;
}
"""


def _bits(values) -> np.ndarray:
    return np.asarray(values, dtype=np.float32).view(np.uint32)


def test_the_key_test_is_the_strict_float_compare_for_every_value(tmp_path):
    pkg = generate_c(presets.paper_design(), tmp_path / "pkg", precision="float")
    src = tmp_path / "probe.c"
    src.write_text(PROBE)
    exe = tmp_path / "probe"
    subprocess.run([find_compiler(), "-O2", "-std=c99", "-w", f"-I{pkg.out_dir}", "-o", str(exe),
                    str(src)], check=True, timeout=120, cwd=pkg.out_dir)
    f32 = np.finfo(np.float32)
    tiny = np.float32(1e-45)
    special = [0.0, -0.0, tiny, -tiny, f32.tiny, -f32.tiny, 1.0, -1.0, 2.5, -2.5, f32.max,
               -f32.max, np.inf, -np.inf, np.nan, -np.nan]
    rng = np.random.default_rng(7)
    random_bits = rng.integers(0, 2**32, size=600, dtype=np.uint64).astype(np.uint32)
    values = np.concatenate([_bits(special), random_bits,
                             _bits(np.nextafter(np.float32([2.5, -2.5, 1.0, 0.0]),
                                                np.float32([3.0, -3.0, 2.0, 1.0])))])
    limits = [(-2.5, 2.5), (0.0, 1.0), (-0.0, 1.0), (-1.0, 0.0), (-1.0, -0.0), (1.0, 2.0),
              (-2.0, -1.0), (tiny, 3 * tiny), (-f32.max, f32.max), (0.0, tiny), (-0.0, 0.0),
              (1.0, 1.0), (2.0, 1.0)]
    lines, expected = [], []
    for lo, hi in limits:
        blo, bhi = (int(b) for b in _bits([lo, hi]))
        lo32, hi32 = np.float32(lo), np.float32(hi)
        v32 = values.view(np.float32)
        with np.errstate(invalid="ignore"):
            # the common path only with validated limits (u_min < u_max): else never
            inside = (lo32 < v32) & (v32 < hi32) & (lo32 < hi32)
        lines += [f"{blo:x} {bhi:x} {int(v):x}" for v in values]
        expected += inside.astype(int).tolist()
    out = subprocess.run([str(exe)], input="\n".join(lines) + "\n", capture_output=True,
                         text=True, check=True, timeout=120).stdout.split()
    got = np.array(out, dtype=int)
    wrong = np.flatnonzero(got != np.array(expected))
    assert wrong.size == 0, [lines[i] for i in wrong[:10]]
    assert 0 < got.sum() < got.size  # both answers occur
