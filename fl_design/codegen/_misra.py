"""MISRA C:2012 deviations of the generated firmware source, with their reasons.

``cppcheck --addon=misra`` finds no violation of a *required* rule in ``<prefix>.c`` (the
firmware source); the *advisory* rules it reports are deviated from on purpose, each for the
reason below. The package's ``MISRA_DEVIATIONS.md`` is written from :data:`DEVIATIONS`, and
``tests/codegen/test_misra.py`` checks that every rule cppcheck reports is one of them. The
host-only programs (``main.c``, ``check.c``, ``pil/``) use ``<stdio.h>`` and are outside the
firmware's scope; their findings are listed separately (:data:`HOST_ONLY`).

Examples
--------
>>> from fl_design.codegen._misra import DEVIATIONS, deviation_text
>>> sorted(DEVIATIONS)[:3]
['10.5', '12.1', '15.5']
>>> "| 15.5 | advisory |" in deviation_text("fl", "0123")
True
"""

from __future__ import annotations

#: advisory rules of MISRA C:2012 the firmware source deviates from: rule -> reason
DEVIATIONS = {
    "2.3": "The union type of the bit-pattern helper is anonymous and local; the header's "
           "`PREFIX_real_t` typedef is for the firmware's use, and "
           "`PREFIX_telemetry_is_packed` is a compile-time check of the frame's size (an "
           "array of size -1 if the frame had padding), never used as a type.",
    "2.5": "The header's macros (sizes, fault bits, result codes, version, hash, units) are "
           "the API for the firmware; the package itself uses only some of them.",
    "8.7": "`PREFIX_default_params`, `PREFIX_set_params`, `PREFIX_reset`... are the API: "
           "external linkage on purpose, though only the harness calls them.",
    "8.9": "The start tables (`PREFIX_initial_state`, `PREFIX_start0/1`) stay at file scope "
           "next to the generated constants so that a reviewer reads them in one place.",
    "10.5": "A comparison result used as a 0/1 number (the least-squares estimator's window "
            "test) is cast to the real type on purpose; the value is exactly 0 or 1.",
    "12.1": "The generated arithmetic prints `(a > b ? a : b)` selects and the harness's "
            "`?:` without extra parentheses around the comparison; C's precedence is "
            "unambiguous there and the code is machine-written.",
    "15.5": "Early returns: each rejection or validation failure returns at once (a fault "
            "path that falls through would be harder to review).",
    "19.2": "A union gives the bit pattern of a float (the NaN/infinity test that no "
            "compiler flag can remove); type punning through a union is defined in C99 "
            "(6.5.2.3 footnote 82) and needs no `memcpy` (rule 21.15) or pointer cast (11.3).",
}
#: findings in the host-only programs (not part of the firmware): rule -> reason
HOST_ONLY = {
    "21.6": "`main.c` and `check.c` read and print text with `<stdio.h>`: host programs.",
    "17.7": "The harness ignores `scanf`'s count where the loop condition already tests it.",
    "18.4": "The harness's line parsing.",
}


def deviation_text(prefix: str, digest: str) -> str:
    """The package's ``MISRA_DEVIATIONS.md``.

    Parameters
    ----------
    prefix : str
        C prefix (the source is ``<prefix>.c``).
    digest : str
        The design's hash.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.codegen._misra import deviation_text
    >>> deviation_text("trms", "ab").splitlines()[0]
    '# MISRA C:2012 deviations of trms.c'
    """
    rows = [f"| {rule} | advisory | {why.replace('PREFIX', prefix)} |"
            for rule, why in sorted(DEVIATIONS.items(), key=lambda kv: _key(kv[0]))]
    host = [f"| {rule} | {why} |" for rule, why in sorted(HOST_ONLY.items(),
                                                        key=lambda kv: _key(kv[0]))]
    return "\n".join([
        f"# MISRA C:2012 deviations of {prefix}.c",
        "",
        (f"Design hash {digest}. Checked with `cppcheck --addon=misra {prefix}.c` (cppcheck's "
        "MISRA C:2012 addon): **no violation of a required or mandatory rule**. The advisory "
        "rules below are deviated from on purpose; fl_design's tests run cppcheck on the "
        "generated sources and fail on any rule not in this table."),
        "",
        "| Rule | Category | Reason |",
        "|---|---|---|",
        *rows,
        "",
        "## Host-only programs (not linked into the firmware)",
        "",
        ("`main.c` (harness), `check.c` (`make check`) and `pil/` (the Cortex-M4 model's "
        "driver) are host or test programs; MISRA's scope is the firmware source above."),
        "",
        "| Rule | Reason |",
        "|---|---|",
        *host,
        "",
    ])


def _key(rule: str) -> tuple[int, int]:
    a, b = rule.split(".")
    return int(a), int(b)


__all__ = ["DEVIATIONS", "HOST_ONLY", "deviation_text"]
