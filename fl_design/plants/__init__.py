"""A small library of benchmark plants, each a validated :class:`fl_design.Plant`.

========================== === === ============= ======================= =============================
plant                      n   rho input range   b range (region)        zero dynamics
========================== === === ============= ======================= =============================
trms_yaw()                 2   2   [-2.5, 2.5]   [3.6, 6.8]              none
trms_yaw(motor_lag=True)   3   3   [-2.5, 2.5]   [3.6, 6.8]              none
pendulum()                 2   2   [-20, 20]     [1, 1]                  none
flexible_joint()           4   4   [-10, 10]     [418.48, 418.48]        none
cart_pendulum()            4   2   [-10, 10]     [0.9109, 0.9524]        damped sway, minimum phase
cart_pendulum(True)        4   2   [-10, 10]     [0.9109, 0.9524]        NOT minimum phase
maglev()                   3   3   [0, 24]       [-174.6, -18.19]        none (b < 0)
========================== === === ============= ======================= =============================

Parameters are keyword overrides, validated; symbols are real (states) and positive
(parameters), so that the derived expressions stay readable. One module per plant family.

Examples
--------
>>> import fl_design as fl
>>> [fl.plants.trms_yaw().relative_degree(), fl.plants.flexible_joint().relative_degree()]
[2, 4]
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_attributes

# plant -> the module defining it, imported on first use (PEP 562): building the TRMS does not
# import the other families' modules
_LAZY = {"trms_yaw": "_rotor", "pendulum": "_pendulums", "cart_pendulum": "_pendulums",
         "flexible_joint": "_flexible_joint", "maglev": "_maglev"}

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from ._flexible_joint import flexible_joint
    from ._maglev import maglev
    from ._pendulums import cart_pendulum, pendulum
    from ._rotor import trms_yaw


__getattr__, __dir__ = lazy_attributes(__name__, _LAZY, globals())


__all__ = ["cart_pendulum", "flexible_joint", "maglev", "pendulum", "trms_yaw"]
