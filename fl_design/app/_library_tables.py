"""Each library plant's configuration values and the ranges derived from a design point.

:func:`library_tables` turns a library plant's bench design
(:func:`fl_design.presets.bench_design`) and bench step into the config's values;
:func:`default_ranges` gives the ``[sweep]`` and ``[certify]`` ranges from the design's ``T``,
``eps`` and ``gamma``; :func:`fill_ranges` fills the ranges a config did not give;
:func:`plain_toml` writes tables as plain TOML. Plain data: this module imports nothing of
:mod:`fl_design.app`, so the config (:mod:`._config`) and ``init``'s template
(:mod:`._template`) both use it without an import circle.

Examples
--------
>>> from fl_design.app._library_tables import full_tables
>>> full_tables("maglev")["design"]["gamma"]
-0.0016
"""

from __future__ import annotations

import math

#: Units of each library plant's output and input (axis labels of the report).
UNITS = {"trms": ("rad", "V"), "trms-lag": ("rad", "V"), "pendulum": ("rad", "N m"),
         "flexible-joint": ("rad", "N m"), "cart-pendulum": ("m", "N"), "maglev": ("m", "V")}
#: Length of the compared runs and of software in the loop per library plant (s): a few times
#: the bench step's settling time (measured: trms-lag 19.3 s, flexible-joint 2.7 s,
#: cart-pendulum 2.9 s, maglev 0.51 s, pendulum 17.5 s).
_RUN_LENGTH = {"trms": 30.0, "trms-lag": 40.0, "pendulum": 30.0, "flexible-joint": 6.0,
               "cart-pendulum": 6.0, "maglev": 2.0}

#: Library plants whose stable window is narrower than the default ranges: the maglev's loop
#: converges only for |gamma| in about [6e-4, 2.4e-3] and eps below about 3 ms (fl.sweep,
#: 3 s runs); the map is drawn around that window.
_RANGES = {"maglev": {"sweep": {"eps": [1.2e-3, 6e-3], "gamma": [-1e-2, -2e-4]},
                      "certify": {"gamma": [-3e-3, -6e-4]}}}

#: The paper's noise std sqrt(1e-3) relative to its 0.3 rad step.
_PAPER_NOISE = math.sqrt(1e-3) / 0.3

def default_ranges(eps: float, T: float, gamma: float) -> dict:
    """The ``[sweep]`` and ``[certify]`` ranges around a design point, from ``T``, eps, gamma.

    eps from ``max(2 T, eps/10)`` (the observer no faster than half the sampling rate) to
    ``20 eps``; gamma over ``[gamma/10, 100 gamma]`` for the map and ``[gamma/2, 10 gamma]``
    for the certificates, with the sign of gamma (the sign of ``b``). For the paper's TRMS
    (eps 0.05, T 1 ms, gamma 3e-4) these are the paper's ranges.

    Parameters
    ----------
    eps, T, gamma : float
        The design point (gamma nonzero, either sign).

    Returns
    -------
    dict
        ``sweep_eps``, ``sweep_gamma``, ``certify_gamma``, ``certify_eps`` (lists [lo, hi]).

    Examples
    --------
    >>> from fl_design.app._library_tables import default_ranges
    >>> r = default_ranges(0.05, 1e-3, 3e-4)
    >>> r["sweep_eps"], [round(g, 9) for g in r["sweep_gamma"]]
    ([0.005, 1.0], [3e-05, 0.03])
    >>> default_ranges(2e-3, 1e-3, -1e-3)["certify_gamma"]
    [-0.01, -0.0005]
    """
    lo = max(2.0 * T, eps / 10.0)
    eps_r = [round_sig(lo), round_sig(max(20.0 * eps, 4.0 * lo))]

    def span(a, b):
        v = [round_sig(gamma * a), round_sig(gamma * b)]
        return sorted(v)
    return {"sweep_eps": eps_r, "certify_eps": list(eps_r), "sweep_gamma": span(0.1, 100.0),
            "certify_gamma": span(0.5, 10.0)}


def round_sig(x: float) -> float:
    """``x`` to 6 significant digits (the values a config shows)."""
    return float(f"{x:.6g}")


def library_tables(name: str) -> dict:
    """A library plant's tables (without the ranges: see :func:`default_ranges`).

    Parameters
    ----------
    name : str
        A library plant (``fl-design --plant`` name).

    Returns
    -------
    dict
        ``plant``, ``design``, ``scenario``, ``compare``, ``sweep``, ``certify``, ``codegen``.

    Examples
    --------
    >>> from fl_design.app._library_tables import library_tables
    >>> library_tables("flexible-joint")["design"]["gains"]
    [625.0, 500.0, 150.0, 20.0]
    """
    from ..presets import BENCH_REFERENCES, bench_design

    d = bench_design(name)
    est, ctrl = d.estimator, d.controller
    ref = BENCH_REFERENCES[name]
    step = abs(ref - (6e-3 if name == "maglev" else 0.0))
    length = _RUN_LENGTH[name]
    y_unit, u_unit = UNITS[name]
    limits = [] if ctrl.estimate_limits is None else \
        ["none" if v is None else float(v) for v in ctrl.estimate_limits]
    return {
        "plant": {"library": name, "output_unit": y_unit, "input_unit": u_unit},
        "design": {"estimator": "ehgo", "eps": float(est.eps), "T": float(est.T),
                   "coeffs": [float(c) for c in est.coeffs] if est.coeffs is not None else
                   [float(math.comb(d.rho + 1, k)) for k in range(1, d.rho + 2)],
                   "gains": [float(k) for k in ctrl.gains], "gamma": float(ctrl.gamma),
                   "ki": float(ctrl.ki),
                   "u_limits": [] if ctrl.u_limits is None else [float(v) for v in ctrl.u_limits],
                   "estimate_limits": limits},
        "scenario": {"reference": float(ref), "duration": "adaptive", "noise_std": 0.0,
                     "seed": 1},
        "compare": {"windows": [9, 26], "noise_std": [round_sig(step / 300), float(f"{step * _PAPER_NOISE:.10g}")],
                    "eps_tradeoff": [round_sig(est.eps * f) for f in (0.4, 1.0, 2.0, 4.0, 10.0)
                                     if est.eps * f >= est.T],
                    "seed": 1, "duration": length},
        "sweep": {"points": 16, "duration": "adaptive"} | _RANGES.get(name, {}).get("sweep", {}),
        "certify": {"enabled": True, "points": 8} | _RANGES.get(name, {}).get("certify", {}),
        "codegen": {"enabled": True, "precision": "double", "prefix": "fl",
                    "sil_duration": min(length, 10.0)},
    }


def toml_value(v) -> str:
    """A TOML value (strings, numbers, booleans, arrays, inline tables, disturbances)."""
    from collections.abc import Mapping

    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else "nan"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    if hasattr(v, "sampled"):  # a fl.Disturbance of steps and sines
        spec = {where: {d["kind"]: {k: x for k, x in d.items() if k != "kind"}}
                for where, d in v.to_dict().items() if d is not None}
        return toml_value(spec)
    return str(v)


def plain_toml(tables: dict) -> str:
    """Plain TOML of ``{table: {key: value}}`` (no comments).

    Parameters
    ----------
    tables : dict
        ``{table: {key: value}}``.

    Examples
    --------
    >>> plain_toml({"scenario": {"reference": 0.3}})
    '[scenario]\\nreference = 0.3\\n'
    """
    return "\n".join(f"[{t}]\n" + "".join(f"{k} = {toml_value(v)}\n" for k, v in body.items())
                     for t, body in tables.items())


def full_tables(name: str) -> dict:
    """A library plant's tables with the default ranges filled in (what ``init`` writes).

    Parameters
    ----------
    name : str
        A library plant's config name (``--plant`` choices: ``trms``, ``pendulum``, ...).

    Returns
    -------
    dict
        ``{table: {key: value}}``, every range filled.

    Examples
    --------
    >>> from fl_design.app._library_tables import full_tables
    >>> full_tables("trms")["certify"]["gamma"]
    [0.00015, 0.003]
    """
    t = library_tables(name)
    fill_ranges(t, {})
    return t


def fill_ranges(tables: dict, given: dict) -> None:
    """Fill the ``[sweep]`` and ``[certify]`` ranges the user did not give, from ``[design]``.

    Parameters
    ----------
    tables : dict
        The merged tables (``design`` holds eps, T, gamma).
    given : dict
        The user's tables (what they gave is kept).

    Examples
    --------
    >>> from fl_design.app._library_tables import fill_ranges
    >>> given = {"sweep": {"eps": [0.01, 0.1]}}
    >>> t = {"design": {"eps": 0.05, "T": 1e-3, "gamma": 3e-4}, "sweep": {"eps": [0.01, 0.1]},
    ...      "certify": {}}
    >>> fill_ranges(t, given)
    >>> t["sweep"], t["certify"]
    ({'eps': [0.01, 0.1], 'gamma': [3e-05, 0.03]}, {'gamma': [0.00015, 0.003], 'eps_range': [0.01, 0.1]})
    """
    d = tables["design"]
    if not all(isinstance(d.get(k), (int, float)) and not isinstance(d.get(k), bool) and d[k]
               for k in ("eps", "T", "gamma")):
        return
    r = default_ranges(float(d["eps"]), float(d["T"]), float(d["gamma"]))
    # a value already in ``tables`` (the user's, or a library plant's window) is kept
    tables["sweep"].setdefault("eps", r["sweep_eps"])
    tables["sweep"].setdefault("gamma", r["sweep_gamma"])
    tables["certify"].setdefault("gamma", r["certify_gamma"])
    if "eps_range" not in given.get("certify", {}):
        tables["certify"]["eps_range"] = list(tables["sweep"]["eps"])


__all__ = ["UNITS", "default_ranges", "fill_ranges", "full_tables", "library_tables",
           "plain_toml", "round_sig", "toml_value"]
