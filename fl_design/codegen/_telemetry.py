"""``read_telemetry``: the C package's telemetry frames as columns a log identifier reads.

A generated package fills one ``PREFIX_telemetry_t`` frame per sample (``PREFIX_telemetry``
right after ``PREFIX_step``): 16 bytes of integers (magic ``"FLTM"``, version, ``rho``, the
size of a real, the sensor-lost flag, the sample index ``k``, the fault bits), then the reals
``T, y, r, u, xhat_1 .. xhat_rho, sigmahat`` (4 or 8 bytes each, no padding). The firmware
streams the frames (UART, a RAM buffer, SWO); :func:`read_telemetry` reads their bytes back,
in the target's byte order (little-endian by default, as on every Cortex-M).

Examples
--------
>>> import struct
>>> from fl_design.codegen._telemetry import read_telemetry
>>> frame = struct.pack("<IBBBBII" + "f" * 7, 0x4D544C46, 1, 2, 4, 0, 1, 0,
...                     1e-3, 0.1, 0.3, 0.5, 0.1, 0.0, 0.0)
>>> log = read_telemetry(frame)
>>> log.n, log.rho, float(log.t[0]), float(log.u[0])
(1, 2, 0.0, 0.5)
"""

from __future__ import annotations

import csv
import os
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ParameterError

#: ``"FLTM"`` as a little-endian ``uint32``
MAGIC = 0x4D544C46
#: frame versions this reader understands
VERSIONS = (1,)
_HEAD = 16


@dataclass(frozen=True)
class Telemetry:
    """Telemetry frames as columns.

    Parameters
    ----------
    k : numpy.ndarray
        ``(N,)`` sample indices.
    t : numpy.ndarray
        ``(N,)`` times ``(k - 1) T`` (s): the first step after ``PREFIX_init`` at 0.
    y, r, u : numpy.ndarray
        ``(N,)`` measurement, reference and applied input.
    xhat : numpy.ndarray
        ``(N, rho)`` estimates of ``y`` and its derivatives.
    sigmahat : numpy.ndarray
        ``(N,)`` estimate of the lumped term.
    fault : numpy.ndarray
        ``(N,)`` fault bits (``PREFIX_FAULT_*``; 0: accepted).
    sensor_lost : numpy.ndarray
        ``(N,)`` booleans.
    T : float
        Sampling time (s).
    precision : str
        ``"double"`` or ``"float"``: the package's.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.codegen._telemetry import Telemetry
    >>> z = np.zeros(2)
    >>> Telemetry(z, z, z, z, z, np.zeros((2, 1)), z, z.astype(int), z.astype(bool), 1e-3,
    ...           "float").columns()[:4]
    ['t', 'y', 'u', 'r']
    """

    k: np.ndarray
    t: np.ndarray
    y: np.ndarray
    r: np.ndarray
    u: np.ndarray
    xhat: np.ndarray
    sigmahat: np.ndarray
    fault: np.ndarray
    sensor_lost: np.ndarray
    T: float
    precision: str

    @property
    def n(self) -> int:
        """Number of frames."""
        return int(self.k.size)

    @property
    def rho(self) -> int:
        """Relative degree of the design that wrote the log."""
        return int(self.xhat.shape[1])

    def columns(self) -> list[str]:
        """Column names of :meth:`table`: ``t, y, u, r``, the estimates, ``fault``, ``k``."""
        return (["t", "y", "u", "r"] + [f"xhat_{i + 1}" for i in range(self.rho)]
                + ["sigmahat", "fault", "sensor_lost", "k"])

    def table(self) -> np.ndarray:
        """``(N, len(columns()))`` float array, the columns of :meth:`columns`.

        Examples
        --------
        >>> import struct
        >>> from fl_design.codegen._telemetry import read_telemetry
        >>> f = struct.pack("<IBBBBII" + "d" * 6, 0x4D544C46, 1, 1, 8, 0, 7, 2,
        ...                 0.01, 0.2, 0.3, 0.4, 0.2, 0.0)
        >>> [round(v, 12) for v in read_telemetry(f).table()[0].tolist()]
        [0.06, 0.2, 0.4, 0.3, 0.2, 0.0, 2.0, 0.0, 7.0]
        """
        return np.column_stack([self.t, self.y, self.u, self.r, self.xhat, self.sigmahat,
                                self.fault, self.sensor_lost, self.k]).astype(float)

    def to_csv(self, path) -> Path:
        """Write the table as CSV with a header row (what ``fl.identify`` reads: t, y, u, r).

        Parameters
        ----------
        path : path-like
            The file (created or replaced).

        Returns
        -------
        pathlib.Path

        Examples
        --------
        >>> import struct, tempfile, os
        >>> from fl_design.codegen._telemetry import read_telemetry
        >>> f = struct.pack("<IBBBBII" + "d" * 6, 0x4D544C46, 1, 1, 8, 0, 1, 0,
        ...                 0.01, 0.2, 0.3, 0.4, 0.2, 0.0)
        >>> p = read_telemetry(f).to_csv(os.path.join(tempfile.mkdtemp(), "log.csv"))
        >>> p.read_text().splitlines()[0]
        't,y,u,r,xhat_1,sigmahat,fault,sensor_lost,k'
        """
        path = Path(path)
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(self.columns())
            for row in self.table().tolist():
                w.writerow([repr(v) for v in row])
        return path

    def to_dict(self) -> dict:
        """Strict-JSON columns (NaN as None).

        Examples
        --------
        >>> import struct
        >>> from fl_design.codegen._telemetry import read_telemetry
        >>> f = struct.pack("<IBBBBII" + "d" * 6, 0x4D544C46, 1, 1, 8, 0, 1, 0,
        ...                 0.01, float("nan"), 0.3, 0.4, 0.2, 0.0)
        >>> read_telemetry(f).to_dict()["y"]
        [None]
        """
        return {name: [None if not np.isfinite(v) else float(v) for v in col]
                for name, col in zip(self.columns(), self.table().T)}


def _bytes_of(data) -> bytes:
    if isinstance(data, (bytes, bytearray, memoryview)):
        return bytes(data)
    if isinstance(data, (str, os.PathLike)):
        path = Path(data)
        if not path.is_file():
            raise ParameterError(f"telemetry file {str(path)!r} does not exist or is not a file")
        return path.read_bytes()
    raise ParameterError(f"read_telemetry takes bytes or a file path, got {type(data).__name__}")


def read_telemetry(data, *, byteorder: str = "little") -> Telemetry:
    """Decode telemetry frames (bytes, or the path of a file of them) into columns.

    Parameters
    ----------
    data : bytes or path-like
        Concatenated ``PREFIX_telemetry_t`` frames.
    byteorder : {"little", "big"}, optional
        The target's byte order.

    Returns
    -------
    Telemetry

    Raises
    ------
    ParameterError
        Not bytes or a path; empty; a frame whose magic, version, ``rho`` or real size is not
        the first frame's or not known (named with its index and byte offset); trailing bytes
        that are not a whole frame.

    Examples
    --------
    >>> from fl_design.codegen._telemetry import read_telemetry
    >>> read_telemetry(b"")
    Traceback (most recent call last):
    ...
    fl_design.errors.ParameterError: no telemetry frame: the data is empty
    """
    raw = _bytes_of(data)
    if byteorder not in ("little", "big"):
        raise ParameterError(f"byteorder={byteorder!r} is not known; valid: 'little', 'big'")
    if not raw:
        raise ParameterError("no telemetry frame: the data is empty")
    end = "<" if byteorder == "little" else ">"
    head = struct.Struct(end + "IBBBBII")
    if len(raw) < _HEAD:
        raise ParameterError(f"{len(raw)} bytes are less than one frame's 16-byte header")
    magic, version, rho, size, _, _, _ = head.unpack_from(raw, 0)
    if magic != MAGIC:
        raise ParameterError(f"frame 0 (byte 0): magic 0x{magic:08X} is not 0x{MAGIC:08X} "
                             "('FLTM'): not an fl_design telemetry log, or the other byte order")
    if version not in VERSIONS or size not in (4, 8) or rho < 1:
        raise ParameterError(f"frame 0: version {version}, rho {rho}, real size {size}: this "
                             f"reader knows versions {VERSIONS}, real sizes 4 and 8, rho >= 1")
    n_real = 4 + rho + 1
    frame = _HEAD + n_real * size
    if len(raw) % frame:
        raise ParameterError(f"{len(raw)} bytes are not a whole number of {frame}-byte frames "
                             f"(rho {rho}, {size}-byte reals): {len(raw) % frame} bytes left")
    n = len(raw) // frame
    ints = np.ndarray((n,), dtype=np.dtype([("magic", end + "u4"), ("version", "u1"),
                                            ("rho", "u1"), ("size", "u1"), ("lost", "u1"),
                                            ("k", end + "u4"), ("fault", end + "u4"),
                                            ("reals", f"{end}f{size}", (n_real,))]),
                      buffer=raw)
    for name, want in (("magic", magic), ("version", version), ("rho", rho), ("size", size)):
        bad = np.flatnonzero(ints[name] != want)
        if bad.size:
            i = int(bad[0])
            raise ParameterError(f"frame {i} (byte {i * frame}): {name} {int(ints[name][i])} "
                                 f"differs from the first frame's {want}")
    reals = ints["reals"].astype(float)
    T = float(reals[0, 0])
    k = ints["k"].astype(np.int64)
    return Telemetry(k=k, t=(k - 1) * T, y=reals[:, 1], r=reals[:, 2], u=reals[:, 3],
                     xhat=reals[:, 4:4 + rho], sigmahat=reals[:, 4 + rho],
                     fault=ints["fault"].astype(np.int64), sensor_lost=ints["lost"] != 0, T=T,
                     precision="float" if size == 4 else "double")


#: the firmware excitation's kinds (``PREFIX_EXCITE_*``)
EXCITATION_KINDS = {"step": 0, "square": 1, "prbs": 2}


def excitation_sequence(kind: str, center: float, amplitude: float, hold: int,
                        n: int) -> np.ndarray:
    """The references ``PREFIX_excite`` returns, computed in Python (the same LFSR and holds).

    Parameters
    ----------
    kind : {"step", "square", "prbs"}
        ``PREFIX_EXCITE_STEP`` (center for one hold, then center + amplitude), ``SQUARE``
        (center +- amplitude, switching every ``hold`` samples), ``PRBS`` (a 16-bit
        maximal-length LFSR's bit, held ``hold`` samples).
    center, amplitude : float
        Operating point and amplitude (>= 0).
    hold : int
        Samples per level (>= 1).
    n : int
        Samples.

    Returns
    -------
    numpy.ndarray

    Raises
    ------
    ParameterError
        Unknown kind, negative or non-finite amplitude, hold < 1.

    Examples
    --------
    >>> from fl_design.codegen._telemetry import excitation_sequence
    >>> excitation_sequence("square", 1.0, 0.5, 2, 6).tolist()
    [1.5, 1.5, 0.5, 0.5, 1.5, 1.5]
    >>> excitation_sequence("step", 0.0, 1.0, 2, 4).tolist()
    [0.0, 0.0, 1.0, 1.0]
    """
    if kind not in EXCITATION_KINDS:
        raise ParameterError(f"excitation kind {kind!r} is not known; valid: "
                             f"{', '.join(map(repr, EXCITATION_KINDS))}")
    if not (np.isfinite(amplitude) and amplitude >= 0 and np.isfinite(center)):
        raise ParameterError(f"excitation center {center!r} and amplitude {amplitude!r} must "
                             "be finite, the amplitude >= 0")
    if int(hold) != hold or hold < 1:
        raise ParameterError(f"excitation hold must be a whole number of samples >= 1, "
                             f"got {hold!r}")
    out, lfsr, level = np.empty(int(n)), 0xACE1, 1.0
    for k in range(int(n)):
        if k % hold == 0:
            if kind == "prbs":
                bit = (lfsr ^ (lfsr >> 2) ^ (lfsr >> 3) ^ (lfsr >> 5)) & 1
                lfsr = ((lfsr >> 1) | (bit << 15)) & 0xFFFF
                level = 1.0 if lfsr & 1 else -1.0
            elif kind == "square" and k > 0:
                level = -level
            elif kind == "step":
                level = 1.0 if k > 0 else 0.0
        out[k] = center + amplitude * level
    return out


__all__ = ["EXCITATION_KINDS", "MAGIC", "VERSIONS", "Telemetry", "excitation_sequence",
           "read_telemetry"]
