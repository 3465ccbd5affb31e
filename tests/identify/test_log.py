"""Bad logs: a clear LogError naming the row or column and what is needed; skipped rows counted."""
import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import ExcitationError, LogError
from fl_design.identification import read_log


def cols(n=1000, T=1e-3, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * T
    return {"t": t, "y": np.sin(t) + 1e-3 * rng.standard_normal(n),
            "u": rng.standard_normal(n)}


def write(tmp_path, c, header="t,y,u"):
    p = tmp_path / "log.csv"
    rows = [header] + [",".join(f"{c[k][i]:.9g}" for k in header.split(",")) for i in
                       range(c["t"].size)]
    p.write_text("\n".join(rows) + "\n")
    return p


def test_a_clean_log_reads_with_its_sampling_time():
    log = read_log(cols(T=2e-3))
    assert log.T == pytest.approx(2e-3) and log.n == 1000 and log.skipped == {}
    assert log.jitter < 1e-12


def test_nan_is_an_error_naming_its_line_and_skip_counts_it(tmp_path):
    c = cols()
    c["y"][10] = np.nan
    c["y"][500] = np.nan
    p = write(tmp_path, c)
    with pytest.raises(LogError, match=r"column 'y' at line 12 \(2 row\(s\) in all\)"):
        read_log(p)
    log = read_log(p, bad_rows="skip")
    assert log.n == 998
    assert log.skipped == {"a missing or non-finite value in column 'y'": 2}
    assert log.first_skipped["a missing or non-finite value in column 'y'"] == "line 12"
    assert len(log.segments) == 3  # the two holes cut the log; no window spans them


def test_time_going_backwards_names_the_row():
    c = cols()
    c["t"][300] = c["t"][100]
    with pytest.raises(LogError, match="time goes backwards at row 300"):
        read_log(c)


def test_a_repeated_time_stamp_is_an_error_or_counted():
    c = cols()
    c["t"][301] = c["t"][300]
    with pytest.raises(LogError, match="repeated time stamp at row 301"):
        read_log(c)
    log = read_log(c, bad_rows="skip")
    assert log.skipped["a repeated time stamp"] == 1 and log.n == 999


def test_too_few_samples():
    with pytest.raises(LogError, match="50 usable samples .* at least 200"):
        read_log(cols(n=50))


@pytest.mark.parametrize("names, hint", [(("time", "y", "u"), "is 'time' the column 't'"),
                                         (("t", "out", "u"), "misses the column\\(s\\) 'y'")])
def test_missing_or_misnamed_columns_say_what_is_needed(names, hint):
    c = cols()
    with pytest.raises(LogError, match=hint):
        read_log(dict(zip(names, (c["t"], c["y"], c["u"]))))


def test_a_non_numeric_cell_names_line_and_column(tmp_path):
    p = write(tmp_path, cols())
    lines = p.read_text().splitlines()
    lines[5] = "0.004,abc,1.0"
    p.write_text("\n".join(lines))
    with pytest.raises(LogError, match="column 'y' at line 6 is 'abc'"):
        read_log(p)


def test_a_file_without_header_is_refused(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("0,1,2\n0.001,1,2\n")
    with pytest.raises(LogError, match="no header row"):
        read_log(p)


def test_milliseconds_given_as_seconds_is_an_implausible_T():
    c = cols()
    c["t"] = c["t"] * 1e3 * 1e3  # microseconds
    with pytest.raises(LogError, match="implausible sampling time .* is t in milliseconds"):
        read_log(c)


def test_mixed_units_break_the_sampling_at_a_named_row():
    c = cols()
    c["t"][700:] = c["t"][699] + 1e-6 * np.arange(1, 301)  # the last 300 rows in ms read as s
    with pytest.raises(LogError, match="before row 700 is 1e-06 s, the median 0.001 s.*mixed"):
        read_log(c)


def test_a_given_T_that_disagrees_is_a_units_error():
    with pytest.raises(LogError, match="not the T = 0.01 s you gave"):
        read_log(cols(), T=1e-2)


def test_constant_u_refuses_with_an_experiment():
    c = cols()
    c["u"][:] = 0.3
    with pytest.raises(ExcitationError, match="constant .* Experiment"):
        fl.identify(c, rho=2)


def test_saturated_throughout_is_refused():
    c = cols()
    c["u"][:] = 10.0
    c["u"][::50] = 3.0
    with pytest.raises(LogError, match="sits at 10 in 98.0 % .* saturated throughout"):
        fl.identify(c, rho=2)


def test_a_log_without_excitation_says_which_experiment_would_do():
    c = cols(n=5000)
    c["u"] = 1e-6 * np.random.default_rng(1).standard_normal(5000)
    with pytest.raises(ExcitationError, match="square wave on u of amplitude"):
        fl.identify(c, rho=2)


def test_a_telemetry_frame_with_a_sample_index_is_dated_by_T():
    c = cols()
    frame = {"sample_index": np.arange(1000, 2000), "y": c["y"], "u": c["u"], "sigmahat": c["u"]}
    with pytest.raises(LogError, match="sample index 'sample_index' but no time column"):
        read_log(frame)
    log = read_log(frame, T=2e-3)
    assert log.T == pytest.approx(2e-3) and log.t[0] == pytest.approx(2.0)
    assert log.extra == ("sigmahat",)


def test_a_millisecond_counter_read_as_seconds_is_flagged():
    c = cols()
    c["t"] = np.arange(1000, 2000, dtype=float)  # 1 kHz in ms: T would read 1 s
    with pytest.raises(LogError, match="whole numbers stepping by 1: a millisecond"):
        read_log(c)
    assert read_log(c, T=1.0).T == 1.0  # said on purpose: a loop sampled every second


def test_jittery_time_stamps_give_T_and_the_jitter():
    c = cols(n=4000)
    c["t"] = c["t"] + np.random.default_rng(3).uniform(-2e-4, 2e-4, 4000)
    log = read_log(c)
    assert log.T == pytest.approx(1e-3, rel=0.02)
    assert 1e-4 < log.jitter < 2.5e-4 and log.jitter_max < 4e-4
