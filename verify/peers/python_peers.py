"""Independent Python peers of the TRMS yaw closed loop for ``verify/bench_sweep.py``.

Hand-written from the paper's equations (the same loop as ``trms_loop.c``; nothing generated
by fl_design, which only supplies the design numbers: the observer matrices per eps, gamma):

* :func:`numpy_loop`: NumPy vectorised over the runs, diverged runs compacted away (their
  remaining samples cost nothing), one Python iteration per sample;
* :func:`numba_loop`: numba ``@njit``, one run at a time (when numba is installed);
* :func:`jax_loop`: JAX ``jit(vmap(lax.scan))`` in float64 (when jax is installed); a diverged
  run is frozen with ``where`` (JAX computes every sample of every run).

Each returns ``(nruns, 6)``: ``k_div`` (-1: none), tail ``max|e|``, ``max e``, ``min e``, final
``x``. ``args`` is the tuple built by ``bench_sweep.peer_args``.
"""

from __future__ import annotations

import math

import numpy as np


def numpy_loop(P, r, N, k_tail, T, substeps, plant, ctrl, bound):
    I2, a2, b2, B1, B2, delta, k2, T20 = plant
    k1, kg2, ki, lim, ulo, uhi = ctrl
    n = P.shape[1]
    A, B, C = P[0:9].reshape(3, 3, n), P[9:12], P[12:21].reshape(3, 3, n)
    Dd, Di, gamma = P[21:24], P[24:27], P[27]
    idx = np.arange(n)
    x0, x1 = np.zeros(n), np.zeros(n)
    xi, u, z = np.zeros((3, n)), np.zeros(n), np.zeros(n)
    e_abs, e_max, e_min = np.zeros(n), np.full(n, -np.inf), np.full(n, np.inf)
    out = np.zeros((n, 6))
    out[:, 0] = -1.0
    h = T / substeps

    def rhs(w, uu):
        tau = k2 * uu / T20
        return (a2 * tau * np.abs(tau) + b2 * tau - B1 * w - B2 * np.tanh(w / delta)) / I2

    for k in range(N):
        y, rk = x0, r[k]
        e = y - rk
        xh = Di * (np.einsum("ijn,jn->in", C, xi) + Dd * y)
        xh1 = np.minimum(np.maximum(xh[1], -lim), lim)
        zn = z + T * (xh[0] - rk)
        v = -k1 * (xh[0] - rk) - kg2 * xh1 - ki * zn
        un = np.minimum(np.maximum(u + gamma * (v - xh[2]), ulo), uhi)
        xin = np.einsum("ijn,jn->in", A, xi) + B * y
        p, w = x0.copy(), x1.copy()
        for _ in range(substeps):
            a1 = rhs(w, un)
            b1 = rhs(w + 0.5 * h * a1, un)
            c1 = rhs(w + 0.5 * h * b1, un)
            d1 = rhs(w + h * c1, un)
            p = p + h / 6.0 * (w + 2.0 * (w + 0.5 * h * a1) + 2.0 * (w + 0.5 * h * b1)
                               + (w + h * c1))
            w = w + h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1)
        ok = ((np.abs(p) <= bound[0]) & (np.abs(w) <= bound[1]) & (np.abs(un) < 1e300)
              & (np.abs(zn) < 1e300) & np.all(np.abs(xin) < 1e300, axis=0))
        if k >= k_tail:
            e_abs = np.where(ok, np.maximum(e_abs, np.abs(e)), e_abs)
            e_max = np.where(ok, np.maximum(e_max, e), e_max)
            e_min = np.where(ok, np.minimum(e_min, e), e_min)
        if not ok.all():  # freeze the diverged runs: store them, drop them from the arrays
            bad = ~ok
            out[idx[bad]] = np.column_stack([np.full(bad.sum(), k + 1.0), e_abs[bad],
                                             e_max[bad], e_min[bad], x0[bad], x1[bad]])
            keep = ok
            idx, A, B, C, Dd, Di, gamma = (idx[keep], A[..., keep], B[:, keep],
                                           C[..., keep], Dd[:, keep], Di[:, keep], gamma[keep])
            p, w, xin, un, zn = p[keep], w[keep], xin[:, keep], un[keep], zn[keep]
            e_abs, e_max, e_min = e_abs[keep], e_max[keep], e_min[keep]
        x0, x1, xi, u, z = p, w, xin, un, zn
        if idx.size == 0:
            break
    out[idx] = np.column_stack([np.full(idx.size, -1.0), e_abs, e_max, e_min, x0, x1])
    return out


def _scalar_loop(P, r, N, k_tail, T, substeps, plant, ctrl, bound, out):
    I2, a2, b2, B1, B2, delta, k2, T20 = plant
    k1, kg2, ki, lim, ulo, uhi = ctrl
    h = T / substeps
    for j in range(P.shape[1]):
        p0, p1 = 0.0, 0.0
        xi0, xi1, xi2, u, z = 0.0, 0.0, 0.0, 0.0, 0.0
        e_abs, e_max, e_min, k_div = 0.0, -math.inf, math.inf, -1.0
        g = P[27, j]
        for k in range(N):
            y, rk = p0, r[k]
            e = y - rk
            xh0 = P[24, j] * (P[12, j] * xi0 + P[13, j] * xi1 + P[14, j] * xi2 + P[21, j] * y)
            xh1 = P[25, j] * (P[15, j] * xi0 + P[16, j] * xi1 + P[17, j] * xi2 + P[22, j] * y)
            xh2 = P[26, j] * (P[18, j] * xi0 + P[19, j] * xi1 + P[20, j] * xi2 + P[23, j] * y)
            xh1 = min(max(xh1, -lim), lim)
            zn = z + T * (xh0 - rk)
            v = -k1 * (xh0 - rk) - kg2 * xh1 - ki * zn
            un = min(max(u + g * (v - xh2), ulo), uhi)
            n0 = P[0, j] * xi0 + P[1, j] * xi1 + P[2, j] * xi2 + P[9, j] * y
            n1 = P[3, j] * xi0 + P[4, j] * xi1 + P[5, j] * xi2 + P[10, j] * y
            n2 = P[6, j] * xi0 + P[7, j] * xi1 + P[8, j] * xi2 + P[11, j] * y
            q0, q1 = p0, p1
            tau = k2 * un / T20
            drive = a2 * tau * abs(tau) + b2 * tau
            for _ in range(substeps):
                a1 = (drive - B1 * q1 - B2 * math.tanh(q1 / delta)) / I2
                w2 = q1 + 0.5 * h * a1
                b1 = (drive - B1 * w2 - B2 * math.tanh(w2 / delta)) / I2
                w3 = q1 + 0.5 * h * b1
                c1 = (drive - B1 * w3 - B2 * math.tanh(w3 / delta)) / I2
                w4 = q1 + h * c1
                d1 = (drive - B1 * w4 - B2 * math.tanh(w4 / delta)) / I2
                q0 = q0 + h / 6.0 * (q1 + 2.0 * w2 + 2.0 * w3 + w4)
                q1 = q1 + h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1)
            ok = (abs(q0) <= bound[0] and abs(q1) <= bound[1] and abs(un) < 1e300
                  and abs(zn) < 1e300 and abs(n0) < 1e300 and abs(n1) < 1e300
                  and abs(n2) < 1e300)
            if not ok:
                k_div = k + 1.0
                break
            if k >= k_tail:
                e_abs, e_max, e_min = max(e_abs, abs(e)), max(e_max, e), min(e_min, e)
            p0, p1, xi0, xi1, xi2, u, z = q0, q1, n0, n1, n2, un, zn
        out[j, 0], out[j, 1], out[j, 2], out[j, 3] = k_div, e_abs, e_max, e_min
        out[j, 4], out[j, 5] = p0, p1


def numba_loop():
    """The ``@njit`` peer, or None when numba is not installed."""
    try:
        import numba
    except ImportError:
        return None
    kernel = numba.njit(cache=False, fastmath=False)(_scalar_loop)

    def run(P, r, N, k_tail, T, substeps, plant, ctrl, bound):
        out = np.zeros((P.shape[1], 6))
        kernel(np.ascontiguousarray(P), r, N, k_tail, T, substeps, np.asarray(plant),
               np.asarray(ctrl), np.asarray(bound), out)
        return out

    return run


def jax_loop():
    """The ``jit(vmap(lax.scan))`` peer (float64), or None when jax is not installed."""
    try:
        import jax
        import jax.numpy as jnp
    except ImportError:
        return None
    jax.config.update("jax_enable_x64", True)

    def one_run(p, r, k_tail, T, substeps, plant, ctrl, bound):
        I2, a2, b2, B1, B2, delta, k2, T20 = (plant[i] for i in range(8))
        k1, kg2, ki, lim, ulo, uhi = (ctrl[i] for i in range(6))
        A, B, C = p[0:9].reshape(3, 3), p[9:12], p[12:21].reshape(3, 3)
        Dd, Di, g = p[21:24], p[24:27], p[27]
        h = T / substeps

        def sub(q, drive):
            q0, q1 = q
            f = lambda w: (drive - B1 * w - B2 * jnp.tanh(w / delta)) / I2
            a1 = f(q1)
            w2 = q1 + 0.5 * h * a1
            b1 = f(w2)
            w3 = q1 + 0.5 * h * b1
            c1 = f(w3)
            w4 = q1 + h * c1
            d1 = f(w4)
            return (q0 + h / 6.0 * (q1 + 2.0 * w2 + 2.0 * w3 + w4),
                    q1 + h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1)), None

        def step(c, kr):
            x, xi, u, z, kd, ea, emx, emn = c
            k, rk = kr
            y = x[0]
            e = y - rk
            xh = Di * (C @ xi + Dd * y)
            xh1 = jnp.minimum(jnp.maximum(xh[1], -lim), lim)
            zn = z + T * (xh[0] - rk)
            v = -k1 * (xh[0] - rk) - kg2 * xh1 - ki * zn
            un = jnp.minimum(jnp.maximum(u + g * (v - xh[2]), ulo), uhi)
            xin = A @ xi + B * y
            tau = k2 * un / T20
            drive = a2 * tau * jnp.abs(tau) + b2 * tau
            if substeps == 1:
                q, _ = sub((x[0], x[1]), drive)
            else:
                q, _ = jax.lax.scan(lambda qq, _: sub(qq, drive), (x[0], x[1]), None,
                                    length=substeps)
            ok = ((jnp.abs(q[0]) <= bound[0]) & (jnp.abs(q[1]) <= bound[1])
                  & (jnp.abs(un) < 1e300) & (jnp.abs(zn) < 1e300) & jnp.all(jnp.abs(xin) < 1e300))
            live = kd < 0
            acc = live & ok
            tail = acc & (k >= k_tail)
            return (jnp.where(acc, jnp.stack(q), x), jnp.where(acc, xin, xi),
                    jnp.where(acc, un, u), jnp.where(acc, zn, z),
                    jnp.where(live & ~ok, k + 1.0, kd),
                    jnp.where(tail, jnp.maximum(ea, jnp.abs(e)), ea),
                    jnp.where(tail, jnp.maximum(emx, e), emx),
                    jnp.where(tail, jnp.minimum(emn, e), emn)), None

        c0 = (jnp.zeros(2), jnp.zeros(3), 0.0, 0.0, -1.0, 0.0, -jnp.inf, jnp.inf)
        c, _ = jax.lax.scan(step, c0, (jnp.arange(r.shape[0], dtype=jnp.float64), r))
        x, _, _, _, kd, ea, emx, emn = c
        return jnp.stack([kd, ea, emx, emn, x[0], x[1]])

    compiled = {}

    def run(P, r, N, k_tail, T, substeps, plant, ctrl, bound):
        key = (N, k_tail, T, substeps, tuple(plant), tuple(ctrl), tuple(bound))
        if key not in compiled:
            fn = lambda p, rr: one_run(p, rr, k_tail, T, substeps, jnp.asarray(plant),
                                       jnp.asarray(ctrl), jnp.asarray(bound))
            compiled[key] = jax.jit(jax.vmap(fn, in_axes=(1, None)))
        return np.asarray(compiled[key](jnp.asarray(P), jnp.asarray(r[:N])))

    return run
