"""loop_margins' crossover and phase margin against the open loop's frequency response in its
complex Schur form (triangular solves: independent of the stacked LU solves that bracket the
crossover, issue 33). SciPy's ``dfreqresp`` goes through a transfer function whose
coefficients lose the poles within 1e-6 of z = 1 at T = 1 ms, and the chain's repeated poles
have no eigenvector basis: neither is used."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

import fl_design as fl
from fl_design.analysis import loop_margins
from fl_design.analysis._margins import open_loop


@pytest.mark.parametrize("make,b", [(fl.presets.paper_design, 3.6), (fl.presets.paper_design, 6.8),
                                    (fl.presets.pendulum_design, 1.0)])
def test_crossover_and_phase_margin_match_scipys_frequency_response(make, b):
    design = make()
    m = loop_margins(design, b, statespace=False)
    A, B, C = open_loop(design, abs(b))
    Ts, Q = scipy.linalg.schur(A, output="complex")  # A = Q Ts Q^H, Ts upper triangular
    Bq, Cq = Q.conj().T @ B, C @ Q

    def L(w):  # -C (z I - A)^-1 B, z = exp(j w T)
        z = np.exp(1j * w * design.T)
        return complex(-(Cq @ scipy.linalg.solve_triangular(z * np.eye(len(B)) - Ts, Bq)))

    assert abs(L(m.crossover)) == pytest.approx(1.0, rel=1e-6)  # |L(w_c)| = 1
    pm = (math.degrees(np.angle(L(m.crossover))) + 360.0) % 360.0 - 180.0
    assert pm == pytest.approx(m.phase_margin, abs=1e-5)
    # every crossing of |L| = 1 on the grid has a margin at least as large
    w = np.geomspace(1e-6 / design.T, math.pi / design.T, 4000)
    mag = np.array([abs(L(x)) for x in w]) - 1.0
    for i in np.flatnonzero(np.sign(mag[:-1]) != np.sign(mag[1:])):
        x = math.sqrt(w[i] * w[i + 1])
        other = (math.degrees(np.angle(L(x))) + 360.0) % 360.0 - 180.0
        assert abs(other) >= abs(m.phase_margin) - 0.5  # within the grid's resolution
