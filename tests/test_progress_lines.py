"""fl_design._progress.Lines: the "auto" mode prints nothing before its delay, then every step."""
import time

import pytest

from fl_design._progress import Lines, check
from fl_design.errors import ParameterError


def test_auto_waits_for_its_delay_then_says_every_step(capsys):
    say = Lines("fl.x", progress="auto", delay=0.05)
    say("first step")
    assert capsys.readouterr().err == ""
    time.sleep(0.06)
    say("second step")
    say("third step")
    err = capsys.readouterr().err.splitlines()
    assert [x.split(" (")[0] for x in err] == ["[fl.x] second step", "[fl.x] third step"]
    assert all(float(x.rsplit("(", 1)[1].rstrip(" s)")) >= 0.05 for x in err)


@pytest.mark.parametrize("bad", ["yes", 1, None, "AUTO"])
def test_a_bad_progress_value_is_named(bad):
    with pytest.raises(ParameterError, match=r"progress=.* is not valid"):
        check(bad)
