"""Servo-mode tracking (mode 1, register 29 servoj): reachable targets are
followed within one control period, far targets within the joint limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from xarm_emu.controller.motion.servo import ServoTracker

DT = 0.004
VMAX, AMAX = math.pi, 20.0


def test_reachable_target_is_followed_in_one_period():
    s = ServoTracker(np.zeros(6), VMAX, AMAX)
    target = np.full(6, 0.9 * VMAX * DT)
    s.set_target(target)
    q, qd, _ = s.step(DT)
    np.testing.assert_array_equal(q, target)
    np.testing.assert_allclose(qd, target / DT)


def test_streamed_smooth_targets_have_no_lag():
    # A 250 Hz stream of a sine well within the limits: every step lands on the newest target.
    s = ServoTracker(np.zeros(7), VMAX, AMAX)
    for k in range(1, 500):
        target = 0.5 * np.sin(np.arange(1, 8) * 0.3 + 2.0 * k * DT) - 0.5 * np.sin(np.arange(1, 8) * 0.3)
        s.set_target(target)
        q, _, _ = s.step(DT)
        np.testing.assert_array_equal(q, target)


def test_far_target_within_limits_no_overshoot_and_exact_arrival():
    s = ServoTracker(np.zeros(3), VMAX, AMAX)
    target = np.array([1.5, -0.7, 0.0])
    s.set_target(target)
    qs, qds = [s.q.copy()], [s.qd.copy()]
    for _ in range(1000):
        q, qd, _ = s.step(DT)
        qs.append(q.copy())
        qds.append(qd.copy())
        if s.at_target:
            break
    qs, qds = np.array(qs), np.array(qds)
    assert s.at_target
    np.testing.assert_array_equal(qs[-1], target)
    assert np.abs(qds).max() <= VMAX * (1 + 1e-12)
    # Speed changes by at most amax*dt per period, except when a joint lands on its target
    # (the landing step is slower than the one before; the next one is at rest).
    dv = np.abs(np.diff(qds, axis=0))
    landing = (qs[1:] == target) | (qs[:-1] == target)
    assert dv[~landing].max() <= AMAX * DT * (1 + 1e-9)
    for j in range(2):
        k = np.argmax(qs[:, j] == target[j])
        assert abs(qds[k, j]) <= abs(qds[k - 1, j])
    for j in range(2):  # never past the target
        sgn = np.sign(target[j])
        assert np.all(sgn * qs[:, j] <= sgn * target[j] + 1e-12)
    # At least the time to ramp up and cruise; not much more than the ideal profile.
    ideal = 1.5 / VMAX + VMAX / AMAX
    t = (len(qs) - 1) * DT
    assert 1.5 / VMAX + 0.5 * VMAX / AMAX <= t <= ideal * 1.1


def test_new_target_mid_motion_reverses_within_acc_limit():
    s = ServoTracker(np.zeros(1), VMAX, AMAX)
    s.set_target([2.0])
    for _ in range(50):
        s.step(DT)
    v_before = s.qd[0]
    assert v_before > 0
    s.set_target([0.0])
    _, qd, _ = s.step(DT)
    assert v_before - qd[0] == pytest.approx(AMAX * DT)


def test_bad_targets_and_limits_refused():
    s = ServoTracker(np.zeros(6), VMAX, AMAX)
    with pytest.raises(ValueError):
        s.set_target([0.0] * 5)
    with pytest.raises(ValueError):
        s.set_target([float("nan")] * 6)
    with pytest.raises(ValueError):
        ServoTracker(np.zeros(6), -1.0, AMAX)
