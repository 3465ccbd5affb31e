"""The package's test-vector file: inputs and expected outputs that ``make check`` replays.

A record of ``N`` samples around the middle of the plausibility range (a first-order approach
to a stepping reference with a slow ripple, two transient faults: a NaN and an out-of-range
sample, which the step rejects and holds ``u``), started as firmware starts
(``PREFIX_start(first y, PREFIX_U_OP)``). The expected ``u`` is ``Design.step`` in double
(CasADi's interpreter, :func:`~fl_design.codegen._compare.reference_run`) over the accepted
samples, held over the rejected ones. The tolerance, written in the file, is absolute:

- double: ``1e-9`` of ``max |u|`` (another compiler may contract ``a*b + c`` into an FMA);
- float: ``4 x`` the float step's own deviation from the double one on this record (its
  bit-exact emulation, :func:`~fl_design.codegen._float_check.emulate`), at least ``1e-5`` of
  ``max |u|``.

Examples
--------
>>> from fl_design.codegen._guard import guard_settings
>>> from fl_design.codegen._vectors import vector_text
>>> d = fl.presets.paper_design()
>>> text = vector_text(d, guard_settings(d), "double", n=50)
>>> text.splitlines()[3].split()[0], len(text.splitlines())
('tol', 54)
"""

from __future__ import annotations

import math

import numpy as np

#: samples in the vector file
N_VECTORS = 1500


def vector_record(lo: float, hi: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(y, r)``: the fault-free record of a vector file over the output range ``[lo, hi]``.

    A first-order approach (40 samples) to a reference stepping from the middle of the range
    to ``+5 %`` of its width, then at half time to ``-2.5 %``, with a slow ripple (period 97
    samples, 2 % of the step); a range of ``1e6`` or wider (no plausibility range) gives
    steps of ``0.1``. The float and Q31 vector files add their own rejected samples.

    Parameters
    ----------
    lo, hi : float
        The output range (the guard's, or the one a Q31 build is scaled for).
    n : int
        Samples.

    Returns
    -------
    tuple of numpy.ndarray
        ``(n,)`` measurements and references.

    Examples
    --------
    >>> from fl_design.codegen._vectors import vector_record
    >>> y, r = vector_record(-10.0, 10.0, 200)
    >>> float(r[0]), float(r[-1]), float(y[0])
    (1.0, -0.5, 0.0)
    """
    mid = 0.5 * (lo + hi)
    amp = 0.05 * (hi - lo) if hi - lo < 1e6 else 0.1
    k = np.arange(n)
    r = mid + amp * np.where(k < n // 2, 1.0, -0.5)
    tau = 40.0  # samples
    y = np.empty(n)
    y[0] = mid
    for i in range(1, n):
        y[i] = y[i - 1] + (r[i] - y[i - 1]) / tau
    y += 0.02 * amp * np.sin(2 * np.pi * k / 97.0)
    return y, r


def hold_rejected(u_kept: np.ndarray, keep: np.ndarray, first) -> np.ndarray:
    """The input at every sample: ``u_kept`` on the accepted ones, held over the rejected.

    The step rejects a sample (``keep`` False) by keeping its last input; before any accepted
    sample that is ``first`` (the operating point's input, as ``PREFIX_start`` sets it).

    Parameters
    ----------
    u_kept : numpy.ndarray
        The inputs computed on the accepted samples, in order.
    keep : numpy.ndarray
        ``(n,)`` bool, which samples were accepted (``u_kept.size == keep.sum()``).
    first : float or int
        The input held before the first accepted sample.

    Returns
    -------
    numpy.ndarray
        ``(n,)``, of ``u_kept``'s dtype.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.codegen._vectors import hold_rejected
    >>> hold_rejected(np.array([1.0, 2.0]), np.array([False, True, False, True]), 0.5).tolist()
    [0.5, 1.0, 1.0, 2.0]
    """
    u_kept = np.asarray(u_kept)
    last = np.cumsum(keep) - 1  # index in u_kept of the last accepted sample so far
    held = u_kept[np.maximum(last, 0)] if u_kept.size else np.zeros(last.size, u_kept.dtype)
    return np.where(last >= 0, held, first).astype(u_kept.dtype)


def _record(guard, n: int):
    """:func:`vector_record` over the guard's range, with a NaN and an out-of-range sample."""
    lo, hi = guard.y_min, guard.y_max
    y, r = vector_record(lo, hi, n)
    bad = {n // 5: math.nan, (3 * n) // 5: 2.0 * max(abs(hi), abs(lo)) + 1.0}
    for i, v in bad.items():
        y[i] = v
    return y, r, sorted(bad)


def expected_inputs(design, guard, precision: str, n: int = N_VECTORS):
    """``(y, r, u_expected, tolerance)`` of the vector file.

    Parameters
    ----------
    design : Design
        The design generated (``CPackage.step_design``).
    guard : GuardSettings
        The checks' defaults (the range, the operating point's input).
    precision : str
        ``"double"`` or ``"float"``.
    n : int, optional
        Samples.

    Returns
    -------
    tuple
        ``(y, r, u_expected, tolerance)``: three arrays of ``n`` samples and a float.

    Examples
    --------
    >>> from fl_design.codegen._guard import guard_settings
    >>> from fl_design.codegen._vectors import expected_inputs
    >>> d = fl.presets.paper_design()
    >>> y, r, u, tol = expected_inputs(d, guard_settings(d), "double", n=100)
    >>> bool(u[20] == u[19]), tol < 1e-9
    (True, True)
    """
    return _expected(design, guard, precision, n)[:4]


def _expected(design, guard, precision: str, n: int):
    """:func:`expected_inputs` and, in float, the emulated step's deviation from
    ``Design.step`` as a fraction of ``max |u|`` (``None`` in double)."""
    from ._compare import reference_run

    y, r, bad = _record(guard, n)
    if precision == "float":
        y, r = y.astype(np.float32).astype(float), r.astype(np.float32).astype(float)
    keep = np.ones(n, bool)
    keep[bad] = False
    state0 = design.initial_state(y0=float(y[0]), u0=guard.u_op)
    u_kept = reference_run(design, y[keep], r[keep], state0=state0)[0]
    u = hold_rejected(np.asarray(u_kept, dtype=float), keep, guard.u_op)
    scale = max(float(np.max(np.abs(u))), np.finfo(float).tiny)
    if precision == "float":
        from ._float_check import emulate

        start = np.asarray(design.initial_state(y0=0.0, u0=guard.u_op), dtype=np.float32)
        u32 = emulate(design, y[keep], r[keep], start, y_c=float(y[0]))
        dev = float(np.max(np.abs(u32.astype(float) - u_kept)))
        return y, r, u, max(4.0 * dev, 1e-5 * scale), dev / scale
    return y, r, u, 1e-9 * scale, None


def vector_text(design, guard, precision: str, *, n: int = N_VECTORS, digest: str = "") -> str:
    """The vector file: ``#`` comment lines, ``tol <abs>``, then one ``y r u`` line per sample.

    Parameters
    ----------
    design, guard, precision, n
        As in :func:`expected_inputs`.
    digest : str, optional
        The design's hash (written in the header).

    Returns
    -------
    str
        The file's text, ready to write as the package's vector file.

    Examples
    --------
    >>> from fl_design.codegen._guard import guard_settings
    >>> from fl_design.codegen._vectors import vector_text
    >>> d = fl.presets.paper_design()
    >>> vector_text(d, guard_settings(d), "float", n=20).startswith("# test vectors")
    True
    """
    return vectors_and_deviation(design, guard, precision, n=n, digest=digest)[0]


def vectors_and_deviation(design, guard, precision: str, *, n: int = N_VECTORS,
                          digest: str = "") -> tuple[str, float | None]:
    """:func:`vector_text` and, in float, the step's own deviation from ``Design.step`` on
    these samples as a fraction of ``max |u|`` (``None`` in double).

    In float the tolerance is ``max(4 dev, 1e-5 max|u|)`` (``dev``: the emulated float
    step's largest deviation); the file states ``dev / max|u|`` in a comment.

    Examples
    --------
    >>> from fl_design.codegen._guard import guard_settings
    >>> from fl_design.codegen._vectors import vectors_and_deviation
    >>> d = fl.codegen.step_design(fl.presets.paper_design(), "float")
    >>> text, dev = vectors_and_deviation(d, guard_settings(d), "float", n=200)
    >>> 0.0 < dev < 1e-4 and "of max|u|" in text
    True
    """
    y, r, u, tol, dev = _expected(design, guard, precision, n)
    comments = [
        f"test vectors of the generated step ({precision}); design hash {digest}",
        "start: PREFIX_start(first y, PREFIX_U_OP); then one PREFIX_step(y, r) per line;",
        "|u - u_expected| <= tol on every line (u_expected: Design.step in double)"]
    if dev is not None:
        comments.append(f"the float step's own deviation from Design.step here: {dev:.3g} of "
                        f"max|u| (tol = max(4 x deviation, 1e-5 max|u|))")
    return vector_file(comments, tol, y, r, u), dev


def vector_file(comments, tol, y, r, u) -> str:
    """The text of a vector file as the package's ``check`` program reads it: ``#`` comment
    lines, ``tol <abs>``, then one ``y r u_expected`` line per sample.

    Parameters
    ----------
    comments : list of str
        The comment lines (without the ``#``).
    tol : float or int
        The absolute tolerance on ``u`` (``0`` for the bit-exact Q31 step).
    y, r, u : numpy.ndarray
        ``(N,)`` measurements, references and expected inputs (floats, or the Q31 step's
        raw integers), each written exactly (``repr``).

    Returns
    -------
    str

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.codegen._vectors import vector_file
    >>> print(vector_file(["a record"], 0, np.array([1]), np.array([2]), np.array([3])), end="")
    # a record
    tol 0
    1 2 3
    """
    head = [f"# {line}" for line in comments] + [f"tol {tol!r}"]
    rows = [f"{a!r} {b!r} {c!r}" for a, b, c in zip(y.tolist(), r.tolist(), u.tolist())]
    return "\n".join(head + rows) + "\n"


__all__ = [
    "N_VECTORS",
    "expected_inputs",
    "hold_rejected",
    "vector_file",
    "vector_record",
    "vector_text",
    "vectors_and_deviation",
]
