"""One BLAS thread for the calling thread while small matrix work runs (OpenBLAS, thread-local).

A sweep's fixed work is many tiny dense problems (a 3 x 3 ``solve`` per observer
discretization). OpenBLAS wakes its thread pool for each call; on a loaded machine (other
processes on every core) the wake-up waits for a time slice: measured here, 64
discretizations took 1.41 s with the default threads and 0.13 s with one. :func:`serial_blas`
sets OpenBLAS's *thread-local* thread count (``openblas_set_num_threads_local``, OpenBLAS >=
0.3.27, exported by the libraries bundled with NumPy and SciPy) to 1 and restores it on exit:
no global setting changes, other threads of the process (a user's large matrix work) keep
theirs, and no dependency is added. Chosen over ``threadpoolctl`` (a dependency, and its limit
is process-wide) and over ``OPENBLAS_NUM_THREADS`` (must be set before NumPy is imported, for
the whole process). Without OpenBLAS (other BLAS, other OS) it does nothing.

Examples
--------
>>> import numpy as np
>>> from fl_design._blas import serial_blas
>>> with serial_blas():
...     x = np.linalg.solve(np.eye(3), np.ones(3))
>>> x.tolist()
[1.0, 1.0, 1.0]
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import re


@functools.lru_cache(maxsize=1)
def _openblas_libraries() -> tuple:
    """Loaded OpenBLAS libraries with a thread-local thread count (Linux: /proc/self/maps).

    Read once per process (NumPy and SciPy load their BLAS at import, before any sweep).
    """
    try:
        with open("/proc/self/maps") as maps:
            paths = sorted(set(re.findall(r"(/\S*openblas\S*\.so\S*)", maps.read())))
    except OSError:
        return ()
    libs = []
    for path in paths:
        try:
            lib = ctypes.CDLL(path)
            fn = lib.openblas_set_num_threads_local
        except (OSError, AttributeError):
            continue
        fn.argtypes, fn.restype = [ctypes.c_int], ctypes.c_int
        libs.append(fn)
    return tuple(libs)


@contextlib.contextmanager
def serial_blas():
    """Within the block, OpenBLAS calls of this thread use one thread (restored on exit).

    Yields
    ------
    int
        Number of OpenBLAS libraries set (0: nothing to do).

    Examples
    --------
    >>> from fl_design._blas import serial_blas
    >>> with serial_blas() as n:
    ...     n >= 0
    True
    """
    setters = _openblas_libraries()
    previous = [fn(1) for fn in setters]
    try:
        yield len(setters)
    finally:
        for fn, value in zip(setters, previous):
            fn(value)


__all__ = ["serial_blas"]
