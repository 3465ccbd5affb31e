"""Shared set-up of the code-generation tests."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def paper_packages(tmp_path_factory):
    """``{"double": CPackage, "float": CPackage}`` of the paper's design, generated once per
    test module into its own temporary folder."""
    from fl_design import presets
    from fl_design.codegen import generate_c

    root = tmp_path_factory.mktemp("paper_c")
    return {prec: generate_c(presets.paper_design(), root / prec, precision=prec)
            for prec in ("double", "float")}
