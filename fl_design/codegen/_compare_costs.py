"""``compare_costs``: generate, build and measure several designs (the paper's cost table).

Above generation (it calls :func:`~fl_design.codegen.generate_c`) and the cost check
(:mod:`fl_design.codegen._cost`).

Examples
--------
>>> from fl_design.codegen._compare_costs import compare_costs
>>> compare_costs.__name__
'compare_costs'
"""

from __future__ import annotations

import re
from pathlib import Path

from ._cost import CostTable, cached_cost
from ._generate import generate_c


def compare_costs(designs: dict, out_dir, *, precision: str = "double",
                  bench_steps: int = 2_000_000, compiler=None, cache: bool = False) -> CostTable:
    """Generate, build and measure each design: the comparison table.

    Parameters
    ----------
    designs : dict
        ``{row name: Design}``, e.g. the EHGO and the least-squares baselines N = 9, 26.
    out_dir : path-like
        One sub-folder per design is written there.
    precision : str, optional
        ``"double"`` or ``"float"``.
    bench_steps : int, optional
        Steps of each timing run.
    compiler : str, optional
        C compiler.
    cache : bool, optional
        Reuse a row measured earlier with the same key (:func:`cost_key`: the same
        generated files, compilers, flags, timing length, code generator and machine) and
        store new rows; the table's ``cached`` says how many rows came from the cache.

    Returns
    -------
    CostTable

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import compare_costs
    >>> t = compare_costs({"EHGO": presets.paper_design(),
    ...                    "LS(26)": presets.least_squares_design(26)}, "cmp", bench_steps=10)
    >>> t.rows[0].flops < t.rows[1].flops
    True
    """
    rows, cached = [], 0
    for i, (name, design) in enumerate(designs.items()):
        folder = Path(out_dir) / (re.sub(r"\W+", "_", name).strip("_") or f"design{i}")
        pkg = generate_c(design, folder, precision=precision)
        if cache:
            row, hit = cached_cost(pkg, name=name, bench_steps=bench_steps, compiler=compiler)
            rows.append(row)
            cached += hit
        else:
            rows.append(pkg.cost(name=name, bench_steps=bench_steps, compiler=compiler))
    return CostTable(tuple(rows), cached=cached)


__all__ = ["compare_costs"]
