"""What a certificate is asked to cover, read as a :class:`~fl_design.PlantClass`.

Every certificate (:func:`fl_design.certify_eps`, :func:`fl_design.certify_gamma`,
:func:`fl_design.eps_star_curve`) takes "the plants" in one of four forms and certifies a class:

* a :class:`~fl_design.PlantClass`: itself (sampled at the design's ``T``);
* a :class:`~fl_design.Plant`: **its class**, :meth:`PlantClass.from_plant` at the design's
  ``T`` (``b``, the slopes of ``sigma`` and ``b``'s rate enclosed over the plant's region and
  input range), never the ``a = 0`` chain;
* a :class:`~fl_design.analysis._plant_bounds.PlantBounds` (enclosures over a parameter box):
  the class of those enclosures, slopes included (the box's damping, stiffness, ... enter);
* a bare ``(b_min, b_max)``: the named chain class :meth:`PlantClass.chain` (``a = 0``), or the
  stated class with the slope box ``a_jacobian_bounds`` when given.

Explicit ``b_rate`` / ``a_jacobian_bounds`` arguments override the class's own (``"plant"``
reads them from a ``PlantBounds``, as before).

Examples
--------
>>> import fl_design as fl
>>> r = resolve_class((3.6, 6.8), None, None, fl.presets.paper_design())
>>> r.cls.source, r.cls.describe()[:40]
('chain', 'chain class: rho = 2, T = 0.001 s, b in ')
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ._plant_bounds import PlantBounds, plant_bounds, resolve
from ._plant_class import PlantClass
from ._surrogate import jacobian_box


@dataclass(frozen=True)
class Resolved:
    """The class certified and the arguments of the loop (see :func:`resolve_class`)."""

    cls: PlantClass
    b_bounds: tuple
    b_rate: float | None
    a_jacobian_bounds: tuple | None
    params: tuple
    rate_source: str | None
    pb: PlantBounds | None


def _is_plant(obj) -> bool:
    from ..symbolic import Plant

    return isinstance(obj, Plant)


def resolve_class(obj, b_rate, a_jacobian_bounds, design, *, screen=None) -> Resolved:
    """Read ``obj`` (class, plant, plant bounds or ``b`` range) as the class certified.

    Parameters
    ----------
    obj : PlantClass, Plant, PlantBounds or (float, float)
        What to certify.
    b_rate, a_jacobian_bounds
        As :func:`fl_design.certify_eps` (None: the class's own).
    design : Design
        Gives ``T`` and ``rho``.
    screen : callable, optional
        ``PlantClass -> bool``: with a Plant, search the largest region whose class passes it
        (:func:`._class_region.plant_class_search`).

    Returns
    -------
    Resolved
    """
    T, rho = design.T, design.rho
    if _is_plant(obj):
        if screen is not None and a_jacobian_bounds is None:
            from ._class_region import plant_class_search

            cls, pb, _ = plant_class_search(obj, design, screen)
        else:
            pb = plant_bounds(obj, T=T, splits=auto_splits(obj))
            cls = PlantClass._from_bounds(obj, pb, T=T)
        return _finish(cls, b_rate, a_jacobian_bounds, pb, "the plant: " + pb.b_rate_source)
    if isinstance(obj, PlantClass):
        cls = obj.with_T(T)
        return _finish(cls, b_rate, a_jacobian_bounds, None,
                       None if cls.b_rate is None else "the class")
    if isinstance(obj, PlantBounds):
        # 'plant' options read the enclosures' values (checked by resolve: T, availability)
        _, rate, box, _, src, _ = resolve(obj, b_rate, a_jacobian_bounds, T)
        if b_rate is None and obj.T is not None and abs(obj.T - T) <= 1e-12 * T:
            rate, src = obj.b_rate, "the plant: " + obj.b_rate_source
        if a_jacobian_bounds is None:
            box = obj.a_jacobian_bounds  # the box's slopes enter (damping, stiffness, ...)
        jacobian_box(box, rho)
        cls = PlantClass(rho=rho, T=T, b=obj.b_bounds, b_rate=rate, a_slopes=box,
                         u_limits=obj.input_range, source="plant", name=obj.plant,
                         params=obj.params, u_eq=obj.u_eq, region=obj.region,
                         notes=(f"enclosures: {obj.method}",) + (
                             () if obj.a_jacobian_bounds is not None else
                             (f"no slope box for a: {obj.jacobian_note}",)))
        return Resolved(cls, cls.b, cls.b_rate, cls.a_slopes, cls.params, src, obj)
    bb, rate, box, params, src, pb = resolve(obj, b_rate, a_jacobian_bounds, T)
    jacobian_box(box, rho)  # a box of another relative degree: DesignMismatchError
    if box is None:
        cls = PlantClass.chain(rho, b=bb, T=T, b_rate=rate)
    else:
        cls = PlantClass(rho=rho, T=T, b=bb, b_rate=rate, a_slopes=box)
    return Resolved(cls, cls.b, rate, cls.a_slopes, tuple(params), src, pb)


#: Most sub-boxes of an enclosure for a certificate given a Plant (8 splits per variable for
#: the TRMS's 3 variables; 4 for the maglev's 4: 52 s of interval arithmetic became ~4 s).
MAX_SUB_BOXES = 512


def auto_splits(plant) -> int:
    """Splits per variable so that the enclosure has at most :data:`MAX_SUB_BOXES` sub-boxes."""
    k = len([s for s in plant.states if s in (plant.region or {})]) + (
        plant.input_range is not None)
    return max(2, min(8, int(MAX_SUB_BOXES ** (1.0 / max(k, 1)) + 1e-9)))


def _finish(cls, b_rate, a_jacobian_bounds, pb, src) -> Resolved:
    """Apply explicit overrides to a class."""
    if a_jacobian_bounds is not None and not isinstance(a_jacobian_bounds, str):
        jacobian_box(a_jacobian_bounds, cls.rho)
        cls = replace(cls, a_slopes=a_jacobian_bounds, structure=())
    if b_rate is not None and not isinstance(b_rate, str):
        cls, src = replace(cls, b_rate=b_rate), "given"
    return Resolved(cls, cls.b, cls.b_rate, cls.a_slopes, cls.params, src, pb)


__all__ = ["Resolved", "resolve_class"]
