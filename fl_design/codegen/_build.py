"""The compiler, flag sets and hash cache as the code-generation layer uses them.

They live on the ground floor, :mod:`fl_design._toolchain`, because the simulation layer's
compiled kernels need them too (no import between ``sim`` and ``codegen``); this module only
names them for the modules of ``codegen``.

Examples
--------
>>> from fl_design.codegen._build import STRICT_CFLAGS
>>> "-Werror" in STRICT_CFLAGS
True
"""

from .._toolchain import (
    CFLAGS,
    SIDECAR_SUFFIX,
    STRICT_CFLAGS,
    build,
    cache_directory,
    compiler_command,
    find_compiler,
    generate_source,
    verified,
)

__all__ = ["CFLAGS", "SIDECAR_SUFFIX", "STRICT_CFLAGS", "build", "cache_directory",
           "compiler_command", "find_compiler", "generate_source", "verified"]
