"""The tuner for a plant class (``fl-design ui --class SPEC``): no model, what the theory assumes.

A :class:`fl_design.PlantClass` has no equations to simulate; the page simulates one member of
it, the chain of ``rho`` integrators ``y^(rho) = b u`` with ``b`` at the geometric mean of the
class's range (said on the page), and computes the certificates for the whole class (its b
range, rate and slopes: :func:`fl_design.certify_eps` and :func:`fl_design.certify_gamma` take
the class). The starting design is a plain one (closed-loop poles at -1/s, ``gamma = 2 T /
b_min`` capped at ``0.5 / b_max``, ``eps = 50 T``), not a certified one: the sliders and the
certificates beside them are there to tune it.

:func:`parse_class_spec` reads ``SPEC`` (``rho=2,T=1e-3,b=1:50,noise_std=1e-3``: numbers only,
never evaluated); :func:`class_toml` writes the member's configuration (a plant from
expressions, read by the project's grammar) for the command line to load.

Examples
--------
>>> from fl_design.ui._class_mode import parse_class_spec
>>> cls = parse_class_spec("rho=2,T=1e-3,b=1:50,noise_std=1e-3")
>>> cls.b, cls.noise_std
((1.0, 50.0), 0.001)
"""

from __future__ import annotations

import math

from ..errors import ParameterError

#: Keys of ``--class``: name -> what it is.
SPEC_KEYS = {"rho": "relative degree (integer)", "T": "sampling time (s)",
             "b": "b range lo:hi (one sign) or one number",
             "b_rate": "bound of |b(k+1) - b(k)| per sample (0: constant b)",
             "noise_std": "sensor noise standard deviation", "delay": "input delay (samples)"}


def _number(key: str, text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise ParameterError(f"--class {key}={text!r} is not a number") from None
    if not math.isfinite(x):
        raise ParameterError(f"--class {key}={text!r} must be finite")
    return x


def parse_class_spec(text: str):
    """The :class:`fl_design.PlantClass` of ``--class`` text (comma-separated ``key=value``).

    Parameters
    ----------
    text : str
        E.g. ``"rho=2,T=1e-3,b=1:50,noise_std=1e-3"``; keys :data:`SPEC_KEYS`; ``rho``, ``T``
        and ``b`` are required.

    Returns
    -------
    fl_design.PlantClass

    Raises
    ------
    ParameterError
        An unknown or repeated key, a value that is not a number, a missing ``rho``, ``T`` or
        ``b``, or what :class:`fl_design.PlantClass` refuses.

    Examples
    --------
    >>> from fl_design.ui._class_mode import parse_class_spec
    >>> parse_class_spec("rho=2,T=1e-3")
    Traceback (most recent call last):
    ...
    fl_design.errors.ParameterError: --class needs rho, T and b (missing: b); e.g. --class rho=2,T=1e-3,b=1:50,noise_std=1e-3
    """
    from ..analysis._plant_class import PlantClass

    if not isinstance(text, str) or not text.strip():
        raise ParameterError("--class is empty: give e.g. rho=2,T=1e-3,b=1:50,noise_std=1e-3")
    values: dict = {}
    for part in text.split(","):
        key, sep, value = part.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or key not in SPEC_KEYS:
            raise ParameterError(f"--class: {part.strip()!r} is not key=value with a key of "
                                 f"{', '.join(SPEC_KEYS)}")
        if key in values:
            raise ParameterError(f"--class: {key} given twice")
        if key == "b":
            lo, colon, hi = value.partition(":")
            values[key] = (_number("b", lo), _number("b", hi) if colon else _number("b", lo))
        elif key in ("rho", "delay"):
            x = _number(key, value)
            if x != int(x):
                raise ParameterError(f"--class {key}={value!r} must be an integer")
            values[key] = int(x)
        else:
            values[key] = _number(key, value)
    missing = [k for k in ("rho", "T", "b") if k not in values]
    if missing:
        raise ParameterError(f"--class needs rho, T and b (missing: {', '.join(missing)}); "
                             "e.g. --class rho=2,T=1e-3,b=1:50,noise_std=1e-3")
    return PlantClass(**values)


def member_b(cls) -> float:
    """The simulated member's ``b``: the geometric mean of the class's range (its sign kept).

    Examples
    --------
    >>> from fl_design.ui._class_mode import member_b, parse_class_spec
    >>> member_b(parse_class_spec("rho=2,T=1e-3,b=1:100"))
    10.0
    """
    lo, hi = cls.b
    return math.copysign(math.sqrt(lo * hi), lo)


def class_toml(cls, *, reference: float | None = None) -> str:
    """The configuration of the class's simulated member and its starting design (TOML).

    Parameters
    ----------
    cls : fl_design.PlantClass
        A class with ``T``.
    reference : float, optional
        The step target (a ``[class]`` config's ``[tune] reference``); default the class's
        operating point (0 when it states none) plus 1, as ``fl-design run`` steps a class.

    Returns
    -------
    str

    Raises
    ------
    ParameterError
        The class has no ``T``.

    Examples
    --------
    >>> from fl_design.ui._class_mode import class_toml, parse_class_spec
    >>> print(class_toml(parse_class_spec("rho=2,T=1e-3,b=1:100")).splitlines()[5])
    rhs = ["x2", "b*u"]
    """
    from ..design import gains_from_poles

    if cls.T is None:
        raise ParameterError("--class needs T (the sampling time, s): e.g. T=1e-3")
    rho, T = cls.rho, cls.T
    b = member_b(cls)
    states = [f"x{i + 1}" for i in range(rho)]
    rhs = states[1:] + ["b*u"]
    sign = math.copysign(1.0, b)
    lo, hi = sorted(abs(x) for x in cls.b)
    gamma = sign * min(2 * T / lo, 0.5 / hi)
    gains = [float(g) for g in gains_from_poles([-1.0] * rho)]
    q = ", ".join(f'"{s}"' for s in states)
    eqs = ", ".join(f'"{e}"' for e in rhs)
    limits = "" if cls.u_limits is None else f"u_limits = [{cls.u_limits[0]!r}, " \
        f"{cls.u_limits[1]!r}]\n"
    y0 = float(cls.operating_point or 0.0)
    r = float(y0 + 1.0 if reference is None else reference)
    return (f'[plant]\nname = "member of the class (chain, b = {b:.4g})"\n'
            f"states = [{q}]\n"
            'input = "u"\n'
            "# the chain of integrators y^(rho) = b u, b at the geometric mean of the class\n"
            f"rhs = [{eqs}]\n"
            'output = "x1"\n'
            f"params = {{ b = {b!r} }}\n"
            f"operating_point = {{ x1 = {y0!r} }}\n\n"
            f"[design]\neps = {50 * T!r}\nT = {T!r}\ngains = {gains!r}\ngamma = {gamma!r}\n"
            f"{limits}\n"
            f"[scenario]\nreference = {r!r}\nduration = 20.0\nnoise_std = {cls.noise_std!r}\n\n"
            f"[sweep]\neps = [{5 * T!r}, {1000 * T!r}]\n"
            f"gamma = [{sign * min(0.05 * T / lo, 0.01 / hi)!r}, {sign * 1.0 / hi!r}]\n")


__all__ = ["SPEC_KEYS", "class_toml", "member_b", "parse_class_spec"]
