"""The one runner of external tools: a hang, a missing tool and a failure are named errors."""
import shutil
import sys

import pytest

from fl_design.codegen._build import run_command
from fl_design.errors import CompilationError, CompilerNotFoundError


def test_a_hung_tool_is_a_named_timeout_not_a_raw_traceback():
    with pytest.raises(CompilationError, match=r"the harness x.*timed out after 0.5 s"):
        run_command([sys.executable, "-c", "import time; time.sleep(30)"],
                    what="the harness x", timeout=0.5)


def test_a_failing_tool_names_its_exit_code_and_stderr():
    with pytest.raises(CompilationError, match=r"exit 3.*boom"):
        run_command([sys.executable, "-c", "import sys; sys.stderr.write('boom'); sys.exit(3)"],
                    what="tool")


def test_a_missing_tool_is_named():
    assert shutil.which("fl-no-such-tool") is None
    with pytest.raises(CompilerNotFoundError, match="fl-no-such-tool"):
        run_command(["fl-no-such-tool"], what="tool")


def test_the_environment_is_passed():
    out = run_command([sys.executable, "-c", "import os; print(os.environ['FL_X'])"],
                      what="env", env={"FL_X": "42", "PATH": ""})
    assert out.strip() == "42"
