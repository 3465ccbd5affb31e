"""The step certificate's start-covering LMI: a Lyapunov matrix whose unit set holds a given
plant start inside the rooms and the input limits' linear regions (one LMI, Clarabel
called directly: :func:`._sdp_sector.start_program`).

:func:`widest_start_p` serves :mod:`._step_cert` as :func:`._covered_lmi.widest_covered_p`
serves the region certificate of :mod:`._ldi`; like it, its answer is a candidate that the
caller re-checks in NumPy (:func:`._sector.solve_ellipsoid`), never a certificate by itself.
It lives apart from :mod:`._covered_lmi` because it reads the LDI's vertex loops
(:mod:`._ldi`), which itself uses :mod:`._covered_lmi`.
"""

from __future__ import annotations

import numpy as np

from ._ldi import DECAY_FRACTION, _coordinates, _vertex_loops
from ._sdp_sector import start_program


def widest_start_p(L, ch, eps, gamma, rooms, Xk):
    """A ``P`` whose unit set covers the start ``Xk`` best inside the rooms and the limits'
    linear regions (one LMI, as :func:`widest_covered_p` with general rows): a candidate that
    :func:`._sector.solve_ellipsoid` re-checks (the step certificate, :mod:`._step_cert`), or
    None."""
    out = _vertex_loops(L, eps, gamma)
    D, margins = out[6], out[7]
    if np.max(margins) >= 0.0 or not np.any(Xk):
        return None
    n = Xk.size
    rows = [(np.eye(n)[i], r) for i, r in rooms.items()]
    rows += [(ch.K[j], ch.room[j]) for j in range(ch.K.shape[0])]
    if not rows:
        return None
    kappa = DECAY_FRACTION * float(-np.max(margins)) / 2.0
    for W in _coordinates(D):
        Wi = np.linalg.inv(W)
        Db = [Wi @ x @ W for x in D]
        x0 = Wi @ Xk
        for k in (0.25 * kappa, 0.02 * kappa):
            Pb = start_program(Db, L.T, k, [(c @ W, r) for c, r in rows], x0)
            if Pb is not None and np.linalg.eigvalsh(Pb)[0] > 0.0:
                return Wi.T @ Pb @ Wi
    return None


__all__ = ["widest_start_p"]
