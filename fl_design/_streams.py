"""Standard streams that cannot break a command: closed, full or ASCII-only terminals.

A command's work (a report folder, a C package) must not be lost because its printed text
cannot be shown. :func:`guard_streams` replaces ``sys.stdout`` and ``sys.stderr`` by
:class:`TolerantStream` wrappers:

* a stream closed at start (``fl-design run >&-``: ``sys.stdout is None``) writes nowhere;
* a write that fails (``> /dev/full``: no space left; an I/O error) is recorded, the rest of the
  output is dropped, and the command goes on; the caller says so once at the end
  (:attr:`TolerantStream.failed`) and exits non-zero;
* text the stream's encoding cannot hold (a plant named ``Pendel θ`` on an ASCII-only
  terminal, ``PYTHONIOENCODING=ascii``) is written with backslash escapes (``\\u03b8``);
* a closed pipe (``| head``) still raises :class:`BrokenPipeError`, which the command line
  turns into its quiet exit;
* on standard output, control characters other than newline and tab (a terminal escape
  sequence in a plant name: ``\x1b]0;title\x07``, ``\x1b[2J``) are written as visible
  escapes (``\x1b``), never acted on by the terminal (standard error keeps them: progress
  bars move the cursor there).

Examples
--------
>>> import io
>>> from fl_design._streams import TolerantStream
>>> out = TolerantStream(io.TextIOWrapper(io.BytesIO(), encoding="ascii"), "stdout")
>>> out.write("theta \\u03b8")
7
>>> out.failed is None
True
"""

from __future__ import annotations

import io
import os
import re
import sys

#: Control characters a terminal acts on (escape sequences, bell, carriage return...).
_TERMINAL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")


class TolerantStream(io.TextIOBase):
    """A text stream that never raises but :class:`BrokenPipeError` (see the module).

    Parameters
    ----------
    stream : text stream or None
        The wrapped stream (None: closed, writes go nowhere).
    name : str
        ``"stdout"`` or ``"stderr"``, for messages.

    Attributes
    ----------
    failed : str or None
        Why writing failed (first failure), None while every write succeeded.
    """

    def __init__(self, stream, name: str):
        super().__init__()
        self._stream, self.name = stream, name
        self._literal = name == "stdout"  # control characters shown, never acted on
        self.failed = None if stream is not None else "it is closed"
        if stream is not None and hasattr(stream, "reconfigure"):
            try:
                stream.reconfigure(errors="backslashreplace")
            except (ValueError, OSError, io.UnsupportedOperation):
                pass

    def _call(self, what, *args):
        if self._stream is None or self.failed is not None:
            return None
        try:
            return getattr(self._stream, what)(*args)
        except BrokenPipeError:
            raise
        except UnicodeEncodeError:
            if what != "write":
                return None
            text = args[0].encode("ascii", "backslashreplace").decode("ascii")
            return self._call(what, text)
        except (OSError, ValueError) as exc:  # full disk, I/O error, closed file
            self.failed = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
            return None

    def write(self, text) -> int:
        shown = _TERMINAL.sub(lambda m: f"\\x{ord(m.group()):02x}", text) \
            if self._literal and isinstance(text, str) else text
        self._call("write", shown)
        return len(text)

    def flush(self) -> None:
        self._call("flush")

    def writable(self) -> bool:
        return True

    def isatty(self) -> bool:
        try:
            return bool(self._stream is not None and self._stream.isatty())
        except (OSError, ValueError):
            return False

    def fileno(self) -> int:
        if self._stream is None:
            raise io.UnsupportedOperation(f"{self.name} is closed")
        return self._stream.fileno()

    def silence(self) -> None:
        """Point the failed stream's descriptor at the null device, so that the interpreter's
        last flush at exit does not fail again with a raw message."""
        try:
            fd = self._stream.fileno() if self._stream is not None else None
        except (OSError, ValueError, io.UnsupportedOperation):
            fd = None
        if fd is None:
            return
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, fd)
        finally:
            os.close(null)

    @property
    def encoding(self):
        return getattr(self._stream, "encoding", "utf-8")

    @property
    def errors(self):
        return "backslashreplace"


def guard_streams() -> tuple[TolerantStream, TolerantStream]:
    """Replace ``sys.stdout`` and ``sys.stderr`` by :class:`TolerantStream` (once); return them.

    Examples
    --------
    >>> import sys
    >>> from fl_design._streams import guard_streams
    >>> saved = sys.stdout, sys.stderr
    >>> out, err = guard_streams()
    >>> sys.stdout is out
    True
    >>> sys.stdout, sys.stderr = saved
    """
    if not isinstance(sys.stdout, TolerantStream):
        sys.stdout = TolerantStream(sys.stdout, "stdout")
    if not isinstance(sys.stderr, TolerantStream):
        sys.stderr = TolerantStream(sys.stderr, "stderr")
    return sys.stdout, sys.stderr


__all__ = ["TolerantStream", "guard_streams"]
