"""``generate_c``: the observer-controller step of a design as a C99 package.

The C is :attr:`fl_design.Design.step` itself, printed instruction by instruction from its
CasADi graph (:mod:`fl_design.codegen._emit`; the loop is never written a second time), with
the controller's numbers read from a run-time parameter block
(:mod:`fl_design.codegen._graph`), plus a wrapper from the template files of
``fl_design/codegen/templates``: ``<prefix>.h`` / ``<prefix>.c`` (``<prefix>_init``,
``<prefix>_start`` (bumpless), ``<prefix>_step``, ``<prefix>_set_params`` (validating),
``<prefix>_default_params``, ``<prefix>_reset``; bit-pattern finite tests, plausibility and
rate checks, sensor-lost state, saturating counters, subnormal flushing; the arithmetic is the
``static`` function ``<prefix>_core``: straight-line, no library call), ``main.c`` (the
harness), ``Makefile``, ``CMakeLists.txt``, ``README.md`` (ISR usage, flags, cost) and ``pil/``
(start-up file, linker script and main of the Cortex-M4 run).

An EHGO is generated in its ``"delta"`` realization in every precision
(:class:`fl_design.EHGO`, parameter ``realization``): the same input-output map as the
design's observer to round-off, with ``A_d - I`` stored with its full relative precision and a
DC gain from ``y`` to the derivative estimates that is zero by construction (the direct form's
drifts at high ``rho`` and small ``eps``; in float its ``A_d`` keeps about two digits of
``A_d - I``); in float, about the last sample (:mod:`fl_design.codegen._float_realize`: no
stored value carries the output's level). ``precision="float"`` is true single precision: ``f``-suffixed literals, no
double anywhere (``-Wdouble-promotion -Wfloat-conversion`` clean).

Examples
--------
>>> from fl_design import presets
>>> from fl_design.codegen import generate_c
>>> pkg = generate_c(presets.paper_design(), "trms_c")
>>> sorted(p.name for p in pkg.files)  # doctest: +NORMALIZE_WHITESPACE
['CMakeLists.txt', 'MISRA_DEVIATIONS.md', 'Makefile', 'README.md', 'check.c', 'fl.c', 'fl.h',
 'main.c', 'model.ld', 'pil.ld', 'pil_main.c', 'pil_semihost.h', 'pil_startup.c', 'startup.c',
 'test_vectors.txt']
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

from .._output import claim_output_folder, record_outputs
from ..design import Design
from ..errors import OutputPathError, ParameterError
from ._compare import FLOAT_BOUND
from ._float_check import _budget, _float_run, _total, fixes
from ._guard import guard_settings
from ._misra import deviation_text
from ._package import CPackage
from ._step import PRECISIONS, check_precision, check_prefix, core_function, step_design
from ._template import render, substitutions
from ._vectors import vectors_and_deviation

if TYPE_CHECKING:  # annotations only (no import at run time)
    from ..symbolic import Plant

#: what :func:`generate_c` does when the float build is predicted to miss its bound
FLOAT_POLICIES = ("warn", "refuse")


def generate_c(design: Design, out_dir, *, precision: str = "double", prefix: str = "fl",
               plant: Plant | None = None, scenario=None, float_policy: str = "warn",
               force: bool = False) -> CPackage:
    """Write the design's loop step as a C99 package (sources, header, harness, Makefile).

    Parameters
    ----------
    design : Design
        EHGO or least-squares design; its :attr:`~fl_design.Design.step` is generated.
    out_dir : path-like
        Folder to write (created if needed): empty, or holding this package's earlier output
        unchanged (:mod:`fl_design._output`); a folder with other files is refused.
    precision : {"double", "float", "q31"}, optional
        ``"float"``: true single precision everywhere (literals, math calls, API), with the
        EHGO in its delta realization (module docstring). ``"q31"``: fixed point for
        FPU-less chips (an EHGO with input limits). ``"q15"`` is refused with its predicted
        quantization error (:class:`~fl_design.errors.PrecisionError`).
    prefix : str, optional
        Prefix of the C names and files (default ``"fl"``): ``fl_step``, ``fl_state_t``,
        ``fl.h``.
    plant : Plant, optional
        The plant: its region gives the default plausibility range of ``y`` and its
        equilibrium input the safe input and ``main.c``'s start
        (:func:`fl_design.codegen._guard.guard_settings`; without it ``|y| <= 1e9`` and
        the controller's ``u0`` or 0).
    scenario : Scenario, optional
        With ``plant`` and ``precision="float"``: predict the float build's error on this run
        (:func:`fl_design.codegen._float_check.predict_float_error`, no compiler needed) before
        writing; the number is :attr:`CPackage.predicted_float_error`.
    float_policy : {"warn", "refuse"}, optional
        Above the float bound (``1e-4`` of ``max |u|``): a
        :class:`~fl_design.errors.FloatPrecisionWarning` (default) or a
        :class:`~fl_design.errors.PrecisionError`, both with the number and the fixes. Within
        a factor 2 below the bound (the estimate's agreement with the closed-loop SIL), a
        warning that :meth:`CPackage.verify` may fail, under either policy.
    force : bool, optional
        Write into ``out_dir`` even when it holds files fl_design did not write (they may be
        replaced).

    Returns
    -------
    CPackage
        The files, with ``verify`` (software-in-the-loop) and ``cost``.

    Raises
    ------
    ParameterError
        Unknown ``precision`` or ``float_policy``, ``prefix`` not a C identifier, ``design``
        not a Design, ``scenario`` without ``plant``.
    PrecisionError
        ``float_policy="refuse"`` and the float build is predicted to miss its bound;
        ``precision="q15"`` (the message gives its predicted error).

    Warns
    -----
    FloatPrecisionWarning
        ``float_policy="warn"`` and the float build is predicted to miss its bound.
    OutputPathError
        ``out_dir`` cannot be created or written.
    OutputExistsError
        ``out_dir`` holds files fl_design did not write (or edited since) and ``force`` is
        False.

    Examples
    --------
    >>> from fl_design import presets
    >>> from fl_design.codegen import generate_c
    >>> pkg = generate_c(presets.paper_design(), "c_float", precision="float", prefix="trms")
    >>> "float trms_step(trms_state_t *s, float y, float r);" in (pkg.out_dir / "trms.h").read_text()
    True
    """
    if precision == "q15":
        _refuse_q15(design, guard_settings(design, plant))
    precision, prefix = check_precision(precision), check_prefix(prefix)
    if not isinstance(design, Design):
        raise ParameterError(f"design must be a fl.Design, got {type(design).__name__}")
    used = step_design(design, precision)
    predicted = _float_prediction(design, precision, plant, scenario, float_policy)
    guard = guard_settings(design, plant)
    if precision == "q31":
        files_of, predicted = _q31_files(used, prefix, guard)
    out = claim_output_folder(out_dir, force=force, what="out_dir")
    try:
        if precision == "q31":
            files = files_of(out)
        else:
            files, deviation = _write_templates(used, out, precision, prefix, guard, plant)
        record_outputs(out, files)
    except OSError as exc:
        raise OutputPathError(f"cannot write the C package into {str(out)!r}: {exc}") from None
    if precision == "float" and predicted is None and deviation > FLOAT_BOUND:
        import warnings

        from ..errors import FloatPrecisionWarning

        warnings.warn(f"precision='float': on the package's own test vectors the "
                      f"single-precision step is {deviation:.3g} of max|u| off Design.step "
                      f"(bound {FLOAT_BOUND:g}; test_vectors.txt's tolerance follows it); "
                      f"{fixes(design)}", FloatPrecisionWarning, stacklevel=2)
    return CPackage(out_dir=out, design=design, step_design=used, precision=precision,
                    prefix=prefix, files=tuple(files), predicted_float_error=predicted,
                    guard=guard)


def _refuse_q15(design, guard) -> None:
    """``precision="q15"``: the named refusal, with the predicted quantization error.

    The Q31 program with every word 16 bits shorter (:func:`~fl_design.codegen._q31_files.
    q15_program`: ``int16_t`` values, one bit of headroom, constants rounded to 16 bits) run by
    the integer model on the Q31 package's vector record, against ``Design.step``."""
    from ..errors import PrecisionError
    from ._compare import FLOAT_BOUND
    from ._q31 import q31_program
    from ._q31_files import q15_program, q31_error, q31_range

    if not isinstance(design, Design):
        raise ParameterError(f"design must be a fl.Design, got {type(design).__name__}")
    used = step_design(design, "q31")
    _q31_checks(used)
    lo, hi, _ = q31_range(guard)
    prog = q31_program(used, (lo, hi))
    err15, err31 = q31_error(used, q15_program(prog), guard), q31_error(used, prog, guard)
    verdict = (f"above the bound {FLOAT_BOUND:g} of max |u|" if err15 > FLOAT_BOUND else
               f"within the bound {FLOAT_BOUND:g}, but the Q15 step is not built")
    lsb = 2.0 ** -(prog.f_state[-2] - 16)
    raise PrecisionError(
        f"precision='q15' is refused: its predicted quantization error is {err15:.3g} of "
        f"max |u| on the vector record ({verdict}; Q31: {err31:.2g}). Every value in 16 bits "
        "(one of headroom) from the same interval analysis: u's resolution becomes "
        f"{lsb:.3g} (u units), and the controller's increments gamma (v - sigmahat) per "
        "sample below it are lost, as are the observer's and the integrator's small updates. "
        "Use precision='q31' (the paper's TRMS design: 764 instructions per step on a "
        "Cortex-M0+, 178 on a Cortex-M3).")


def _q31_checks(design) -> None:
    """The designs the fixed-point builds take: an EHGO with input limits."""
    from ..design import EHGO

    if not isinstance(design.estimator, EHGO):
        raise ParameterError(f"precision='q31' is generated for the EHGO; the "
                             f"{type(design.estimator).__name__}'s window counter has no "
                             "bounded fixed-point range: use precision='float' or 'double'")
    if design.controller.u_range is None:
        raise ParameterError("precision='q31' needs u_limits on the controller (the input's "
                             "fixed-point range)")


#: how far the float error's estimate may be from the closed-loop SIL's measured one: the
#: estimate feeds the double loop's measurements to the float step, the SIL the float loop's own
#: (measured ratios 0.6-1.4 on the presets and the unseen designs of the tests, which assert
#: 0.5-2); an estimate within this factor of the bound warns that the SIL may fail
PREDICTION_FACTOR = 2.0

#: the files of ``make check-m4 / check-m3 / check-m0plus`` (check.c on a QEMU Cortex-M model),
#: in every package
MODEL_FILES = {"model_startup.c.in": "model/startup.c", "model.ld.in": "model/model.ld"}


def _q31_files(design, prefix, guard):
    """The Q31 package's writer (a function of the folder) and its measured error."""
    import warnings

    from ..errors import FloatPrecisionWarning
    from ._q31_files import q31_base, q31_error, q31_range, q31_substitutions, q31_vector_text

    _q31_checks(design)
    _, _, why = q31_range(guard)
    if "assumed" in why:
        warnings.warn(f"precision='q31': {why}", FloatPrecisionWarning, stacklevel=3)
    base = q31_base(design, prefix, guard)
    subs, prog, _ = q31_substitutions(design, prefix, guard, base)
    err = q31_error(design, prog, guard)
    names = {"step_q31.h.in": f"{prefix}.h", "step_q31.c.in": f"{prefix}.c",
             "main_q31.c.in": "main.c", "check_q31.c.in": "check.c", "Makefile.in": "Makefile",
             "CMakeLists.txt.in": "CMakeLists.txt", "README_q31.md.in": "README.md",
             **MODEL_FILES}

    def write(out: Path) -> list[Path]:
        written = []
        (out / "model").mkdir(exist_ok=True)
        for template, name in names.items():
            text = resources.files("fl_design.codegen").joinpath("templates", template)
            path = out / name
            path.write_text(render(text.read_text(), {**subs, "Q31_ERROR": f"{err:.3g}"}))
            written.append(path)
        misra = out / "MISRA_DEVIATIONS.md"
        misra.write_text(deviation_text(prefix, subs["DESIGN_HASH"]))
        vectors = out / "test_vectors.txt"
        vectors.write_text(q31_vector_text(design, prog, guard, subs["DESIGN_HASH"]))
        return [*written, misra, vectors]

    return write, err


def _float_prediction(design, precision, plant, scenario, policy) -> float | None:
    import warnings

    from ..errors import FloatPrecisionWarning, PrecisionError

    if policy not in FLOAT_POLICIES:
        raise ParameterError(f"float_policy={policy!r} is not known; valid: "
                             f"{', '.join(map(repr, FLOAT_POLICIES))}")
    if scenario is not None and plant is None:
        raise ParameterError("scenario= needs plant= (the run on which the float build's "
                             "error is predicted)")
    if precision != "float" or scenario is None:
        return None
    run = _float_run(design, plant, scenario, 10_000)
    err = _total(run)
    if err > FLOAT_BOUND:
        part = _budget(run)  # the same run split: its arithmetic and y's rounding
        text = (f"precision='float': the single-precision step is predicted to be "
                f"{err:.3g} of max|u| off Design.step on this run (bound {FLOAT_BOUND:g}): "
                f"{part['arithmetic']:.3g} from the step's arithmetic, "
                f"{part['measurement']:.3g} from rounding y and r to float before the step "
                f"(the observer amplifies it as any measurement noise); {fixes(design)}")
        if policy == "refuse":
            raise PrecisionError(text)
        warnings.warn(text, FloatPrecisionWarning, stacklevel=3)
    elif err * PREDICTION_FACTOR > FLOAT_BOUND:
        warnings.warn(f"precision='float': the single-precision step is predicted to be "
                      f"{err:.3g} of max|u| off Design.step on this run, within "
                      f"{PREDICTION_FACTOR:g}x of the bound {FLOAT_BOUND:g}: the estimate runs "
                      f"on the double loop's measurements and the closed-loop SIL on the float "
                      f"loop's own (they agree within {PREDICTION_FACTOR:g}x), so "
                      f"CPackage.verify may fail; {fixes(design)}", FloatPrecisionWarning,
                      stacklevel=3)
    return err


def _write_templates(design: Design, out: Path, precision: str, prefix: str, guard,
                     plant) -> tuple[list[Path], float | None]:
    """The files written and, in float, the step's deviation on its test vectors."""
    subs = substitutions(design, precision, prefix, guard, plant)
    names = {"step.h.in": f"{prefix}.h", "step.c.in": f"{prefix}.c",
             "main.c.in": "main.c", "Makefile.in": "Makefile",
             "CMakeLists.txt.in": "CMakeLists.txt", "README.md.in": "README.md",
             "check.c.in": "check.c",
             "pil_main.c.in": "pil/pil_main.c", "pil_startup.c.in": "pil/pil_startup.c",
             "pil_semihost.h.in": "pil/pil_semihost.h", "pil.ld.in": "pil/pil.ld",
             **MODEL_FILES}
    written = []
    (out / "pil").mkdir(exist_ok=True)
    (out / "model").mkdir(exist_ok=True)
    for template, name in names.items():
        text = resources.files("fl_design.codegen").joinpath("templates", template).read_text()
        path = out / name
        path.write_text(render(text, subs))
        written.append(path)
    misra = out / "MISRA_DEVIATIONS.md"
    misra.write_text(deviation_text(prefix, subs["DESIGN_HASH"]))
    written.append(misra)
    vectors = out / "test_vectors.txt"
    text, deviation = vectors_and_deviation(design, guard, precision, digest=subs["DESIGN_HASH"])
    vectors.write_text(text)
    written.append(vectors)
    return written, deviation


__all__ = ["FLOAT_POLICIES", "PRECISIONS", "check_precision", "check_prefix", "core_function", "generate_c",
           "step_design"]
