"""The class of a plant over the largest region (of a few tried) whose class can be certified.

Given a :class:`~fl_design.Plant`, a certificate covers its class
(:meth:`~fl_design.PlantClass.from_plant`): ``b`` and the slopes of ``sigma`` enclosed over a
state region. Over the plant's whole declared region that class can be far larger than the
plant near its operating point (the TRMS's smoothed Coulomb friction has slope -505 only for
``|phi'| < 1 mrad/s`` and about -5 elsewhere; switching between the two grows at every eps):
then nothing is certified. The region is shrunk around the operating point, each state's
room scaled by :data:`SCALES` (then once between the last two), and the first class
certified at half its frozen eps* (:func:`._certify.class_screen`) is kept; the class's description names its region. As the
region shrinks to the operating point, the slope box shrinks to the linearization's slopes
and the certificate to that of the linearized loop: the certified eps* stays below the
linearized eps* (every linearization in the region is a frozen member of the class).

Examples
--------
>>> import fl_design as fl
>>> r = scaled_region(fl.plants.pendulum(), 0.5)
>>> [round(v, 4) for v in r["theta"]]
[-1.5708, 1.5708]
"""

from __future__ import annotations

import math

#: Scales of the room around the operating point tried, largest first.
SCALES = (1.0, 1e-2, 1e-4, 1e-6)


def scaled_region(plant, scale: float) -> dict:
    """``{state name: (lo, hi)}``: the plant's region shrunk by ``scale`` around ``x_op``."""
    out = {}
    for s, x0 in zip(plant.states, plant.x_op):
        lo, hi = (plant.region or {}).get(s, (None, None))
        if lo is None:
            continue
        x0 = float(x0)
        out[str(s)] = (x0 - scale * (x0 - float(lo)), x0 + scale * (float(hi) - x0))
    return out


def _class_at(plant, T: float, scale: float):
    from ._plant_bounds import plant_bounds
    from ._plant_class import PlantClass

    pb = plant_bounds(plant, T=T, region=None if scale == 1.0 else scaled_region(plant, scale))
    return PlantClass._from_bounds(plant, pb, T=T), pb


def plant_class_search(plant, design, screen):
    """``(PlantClass, PlantBounds, note)``: the class over the largest region tried that passes
    ``screen(cls) -> bool`` (a certificate at one eps, :func:`._certify.class_screen`), else
    the whole region's.

    Plants without a slope box (internal dynamics) keep the whole region (nothing shrinks).
    """
    full = _class_at(plant, design.T, 1.0)
    if full[0].a_slopes is None:
        return full + ("",)
    tried, prev = [], None
    for k, scale in enumerate(SCALES):
        cls, pb = full if scale == 1.0 else _class_at(plant, design.T, scale)
        if screen(cls):
            if k == 0:
                return cls, pb, ""
            mid = math.sqrt(prev * scale)
            cls2, pb2 = _class_at(plant, design.T, mid)
            if screen(cls2):
                cls, pb, scale = cls2, pb2, mid
            note = (f"the class over the plant's whole region is not certified "
                    f"({'; '.join(tried)}): the region shrunk {1 / scale:.3g}x around the "
                    "operating point is")
            return _noted(cls, note), pb, note
        tried.append(f"room x{scale:g}: not certified")
        prev = scale
    note = (f"no region tried (room x{', x'.join(f'{s:g}' for s in SCALES)} around the "
            "operating point) gives a certified class: the whole region's class is reported")
    return _noted(full[0], note), full[1], note


def _noted(cls, note: str):
    from dataclasses import replace

    return replace(cls, notes=cls.notes + (note,))


def loop_maker(design, n_b: int, max_pieces: int, loop_cls):
    """``PlantClass -> _Loop`` sharing one surrogate loop (its CasADi Jacobian built once);
    the shared loop is kept on the function as ``.loop``."""
    def make(cls):
        L = loop_cls(design, cls.b, cls.a_slopes, n_b, max_pieces, make.loop)
        make.loop = L.loop
        return L
    make.loop = None
    return make


def class_screen(L, gamma: float, lo: float, hi: float) -> bool:
    """A certificate of ``L``'s class at half its frozen eps* (a coarse eigenvalue scan): the
    cheap test of :func:`._class_region.plant_class_search`."""
    from ._search import frozen_bracket

    fb = frozen_bracket(lambda e: L.frozen_margin(e, gamma), lo, hi, 16, 0.05)
    return fb is not None and L.point(max(lo, 0.5 * fb[0]), gamma).certified


__all__ = ["SCALES", "class_screen", "loop_maker", "plant_class_search", "scaled_region"]
