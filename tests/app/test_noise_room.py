"""A proposed design whose noise gain makes the compared noise saturate u is said before the run
(the ball and beam: noise gain 7.8e4, noise 1.67e-4 -> rms u 13 against a room of 20)."""
from types import SimpleNamespace as NS

from fl_design.app._propose import noise_room_notes


def _tuned(gain, u0, lo, hi):
    return NS(noise_gain=gain, response=NS(u=[u0]), design=NS(controller=NS(u_range=(lo, hi))))


def test_noise_beyond_a_third_of_the_nearer_room_is_warned_with_its_numbers():
    # room from u0 = 4 to the nearer limit 0 is 4; a third of it is 1.333...
    t = _tuned(1000.0, 4.0, 0.0, 24.0)
    assert noise_room_notes(t, [1.3e-3]) == []          # rms u 1.3 < 4 / 3
    (line,) = noise_room_notes(t, [0.0, 1.4e-3])        # rms u 1.4 > 4 / 3; no noise: no line
    assert line.startswith("sensor noise 0.0014 gives rms u 1.4 (noise gain 1e+03)")
    assert "room 4 from u = 4" in line


def test_a_nan_noise_gain_or_no_room_says_nothing():
    assert noise_room_notes(_tuned(float("nan"), 0.0, -1.0, 1.0), [1.0]) == []
    assert noise_room_notes(_tuned(10.0, 1.0, -1.0, 1.0), [1.0]) == []  # u0 at its limit
