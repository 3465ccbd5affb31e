"""Identification layer (``fl_design.identification``; not ``identify``, the function
``fl.identify`` keeps that name): a plant class from a rig's log, with its evidence (``fl.identify``).

Modules: ``_log`` (reading and checking a log: columns, rows, sampling time and jitter),
``_noise`` (sensor noise std and spectrum), ``_estimators`` (two estimators of ``b`` over
windows and the input delay), ``_identify`` (:func:`identify`: the class, its evidence, the
excitation check), ``_page`` (the page with its plots). It sits beside ``tuning`` (it needs the
design layer's EHGO and the analysis layer's :class:`fl_design.PlantClass`), below ``app``.

Examples
--------
>>> from fl_design.identification import identify
>>> identify.__name__
'identify'
"""

from ._identify import Evidence, IdentifiedClass, identify
from ._log import Log, read_log
from ._page import write_page

__all__ = ["Evidence", "IdentifiedClass", "Log", "identify", "read_log", "write_page"]
