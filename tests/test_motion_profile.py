"""Jerk-limited 1-D profiles (manual 1.3, Table 1.2): limits, exact arrival,
time optimality (hand-computed cases and ruckig as an independent oracle)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ruckig import InputParameter, Ruckig, Trajectory

from xarm_emu.controller.motion.profile import SCurve


def _samples(prof, n=1201):
    ts = np.linspace(0.0, prof.duration, n)
    return ts, np.array([prof.sample(t) for t in ts])


def _assert_limits(prof, vmax, amax, jmax, v0=0.0, a0=0.0):
    ts, x = _samples(prof)
    s, v, a = x[:, 0], x[:, 1], x[:, 2]
    tol = 1e-9
    assert np.all(np.abs(v) <= max(vmax, abs(v0)) * (1 + tol) + tol)
    assert np.all(np.abs(a) <= max(amax, abs(a0)) * (1 + tol) + tol)
    dt = ts[1] - ts[0]
    if dt > 0:
        # Finite differences: jerk of a, and consistency of v and a with s.
        assert np.all(np.abs(np.diff(a)) / dt <= jmax * (1 + 1e-6))
        np.testing.assert_allclose(np.diff(s) / dt, 0.5 * (v[1:] + v[:-1]), atol=jmax * dt * dt + 1e-9)
        np.testing.assert_allclose(np.diff(v) / dt, 0.5 * (a[1:] + a[:-1]), atol=jmax * dt + 1e-9)


def _ruckig_duration(d, vmax, amax, jmax):
    inp = InputParameter(1)
    inp.current_position, inp.target_position = [0.0], [d]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [vmax], [amax], [jmax]
    tr = Trajectory(1)
    Ruckig(1).calculate(inp, tr)
    return tr.duration


def test_long_move_duration_is_d_over_v_plus_v_over_a_plus_a_over_j():
    d, v, a, j = 100.0, 50.0, 200.0, 1000.0
    p = SCurve(d, v, a, j)
    assert p.duration == pytest.approx(d / v + v / a + a / j, abs=1e-6)
    assert p.vpeak == v and p.apeak == pytest.approx(a)
    _assert_limits(p, v, a, j)


def test_amax_not_reached_but_vmax_reached():
    # v*j < a^2: the acceleration phase is two jerk ramps of sqrt(v/j).
    d, v, a, j = 100.0, 10.0, 200.0, 1000.0
    p = SCurve(d, v, a, j)
    assert p.duration == pytest.approx(d / v + 2.0 * math.sqrt(v / j), abs=1e-6)
    assert p.apeak < a
    _assert_limits(p, v, a, j)


def test_vmax_not_reached_amax_reached():
    d, v, a, j = 100.0, 1000.0, 200.0, 1000.0
    vp = (-a * a / j + math.sqrt((a * a / j) ** 2 + 4 * a * d)) / 2  # vp^2/a + vp a/j = d
    p = SCurve(d, v, a, j)
    assert p.vpeak == pytest.approx(vp, rel=1e-12)
    assert p.duration == pytest.approx(2 * (vp / a + a / j), abs=1e-6)
    _assert_limits(p, v, a, j)


def test_neither_vmax_nor_amax_reached():
    d, v, a, j = 1.0, 1000.0, 200.0, 1000.0
    tj = (d / (2 * j)) ** (1 / 3)  # four jerk ramps: d = 2 j tj^3
    p = SCurve(d, v, a, j)
    assert p.duration == pytest.approx(4 * tj, abs=1e-6)
    _assert_limits(p, v, a, j)


@settings(max_examples=40, deadline=None)
@given(d=st.floats(1e-3, 2000.0), v=st.floats(0.5, 1000.0), a=st.floats(1.0, 50000.0),
       j=st.floats(10.0, 100000.0), neg=st.booleans())
def test_time_optimal_against_ruckig_and_exact_arrival(d, v, a, j, neg):
    d = -d if neg else d
    p = SCurve(d, v, a, j)
    assert p.duration == pytest.approx(_ruckig_duration(d, v, a, j), abs=1e-6)
    assert p.sample(p.duration) == (d, 0.0, 0.0)
    assert p.sample(p.duration + 5.0) == (d, 0.0, 0.0)
    assert p.sample(-1.0) == (0.0, 0.0, 0.0)
    s_end, v_end, a_end = p.sample(p.duration * (1 - 1e-12))
    assert abs(s_end - d) < 1e-9 * max(1.0, abs(d))
    _assert_limits(p, v, a, j)


def test_zero_distance_and_bad_limits():
    p = SCurve(0.0, 10.0, 10.0, 10.0)
    assert p.duration == 0.0 and p.sample(0.0) == (0.0, 0.0, 0.0)
    for bad in ((10.0, 0.0, 1.0), (float("nan"), 1.0, 1.0), (1.0, -1.0, 1.0), (1.0, 1.0, math.inf)):
        with pytest.raises(ValueError):
            SCurve(1.0, *bad)


def test_sample_is_cheap():
    import time

    p = SCurve(250.0, 100.0, 1000.0, 10000.0)
    t0 = time.perf_counter()
    for i in range(20000):
        p.sample(i * 1e-4)
    per_call = (time.perf_counter() - t0) / 20000
    assert per_call < 20e-6


def test_moving_profile_without_a_solution_is_a_planning_error() -> None:
    """A blend into an absurdly slow move: ruckig's refusal becomes C25's PlanningError, not a crash."""
    from xarm_emu.controller.motion import MovingProfile, PlanningError

    with pytest.raises(PlanningError, match="ruckig"):
        MovingProfile(100.0, 1e-30, 0.0, 1e-30, 1e-30, 10.0)
    long = MovingProfile(100.0, 0.0, 0.0, 1e-5, 1e-5, 10.0)  # slow but solvable: about 1e7 s
    assert long.duration == pytest.approx(1e7, rel=1e-3)
