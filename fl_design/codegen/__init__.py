"""Code-generation layer: C compiler discovery, flag sets, the content-hash build cache.

Modules: ``_build`` (:func:`find_compiler`, :func:`build`, :func:`cache_directory`,
:func:`generate_source`, :data:`CFLAGS`, :data:`STRICT_CFLAGS`).

Examples
--------
>>> from fl_design.codegen import STRICT_CFLAGS
>>> "-Werror" in STRICT_CFLAGS
True
"""

from ._build import CFLAGS, STRICT_CFLAGS, build, cache_directory, find_compiler, generate_source

__all__ = ["CFLAGS", "STRICT_CFLAGS", "build", "cache_directory", "find_compiler",
           "generate_source"]
