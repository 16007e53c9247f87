"""The control period's shortcuts give what the long way gives: joint values checked for finiteness,
the motion limits of the present settings, the state transitions of the table, and the joint speeds
and accelerations (exactly +0 at rest) whatever changed the state between periods."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import call, ready

from xarm_emu.controller.applications import reduced
from xarm_emu.controller.core.state_machine import STATES, TRANSITIONS, Event, fire, next_state
from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import kinematics as kin
from xarm_emu.model.robots import XARM6, joint_values


def test_joint_values_takes_finite_values_whose_sum_overflows() -> None:
    q = [1e308, 1e308, -1e308, 0.0, 0.0, 0.0, 5.0]
    assert joint_values(XARM6, q) == q[:6]
    assert not kin.within_limits(XARM6, q)  # finite, but far outside the limits


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("where", [0, 3, 5])
def test_joint_values_refuses_the_first_value_that_is_not_finite(bad: float, where: int) -> None:
    q = [0.1] * 6
    q[where] = bad
    if where < 5:
        q[5] = -bad if not math.isnan(bad) else math.inf  # a second one that would cancel in a sum
    with pytest.raises(ValueError, match=f"non-finite joint value {bad!r}"):
        joint_values(XARM6, np.array(q))
    assert not kin.within_limits(XARM6, q)


def test_joint_values_ignores_extra_values_and_needs_dof() -> None:
    assert joint_values(XARM6, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, math.nan]) == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    with pytest.raises(ValueError, match="needs 6 joint values, got 5"):
        joint_values(XARM6, [0.0] * 5)


class _Holder:
    motion_state = 0


def test_fire_follows_the_transition_table_for_every_state_and_event() -> None:
    h = _Holder()
    for state in STATES:
        for event in Event:
            h.motion_state = state
            assert fire(h, event) == next_state(state, event) == h.motion_state
            if (state, event) not in TRANSITIONS:
                assert h.motion_state == state


def test_limits_follow_the_settings_and_reduced_mode() -> None:
    emu = Emulator(6)
    ctl = emu.controller
    first = ctl.limits()
    assert ctl.limits() == first
    assert first.tcp_speed_cap == math.inf and first.joint_speed_cap == math.inf
    ctl.settings.tcp_maxacc = first.tcp_maxacc / 2
    assert ctl.limits().tcp_maxacc == first.tcp_maxacc / 2
    r = reduced.reduced_of(ctl)
    r.tcp_speed, r.joint_speed, r.on = 100.0, 1.0, True
    capped = ctl.limits()
    assert (capped.tcp_speed_cap, capped.joint_speed_cap) == (100.0, 1.0)
    r.on = False
    assert ctl.limits().tcp_speed_cap == math.inf


def _at_rest_after_a_move() -> Emulator:
    emu = Emulator(6, exact_steps=True)
    ready(emu)
    call(emu, 23, joints=(0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0)
    emu.advance(2.0)
    d = emu.controller.data
    assert emu.controller.state == 2
    assert not (d.qd.any() or d.qdd.any() or np.signbit(d.qd).any() or np.signbit(d.qdd).any())
    return emu


def test_speeds_at_rest_are_recomputed_when_something_replaces_them() -> None:
    emu = _at_rest_after_a_move()
    ctl = emu.controller
    d = ctl.data
    dt = ctl.period
    d.qd = np.full(6, 0.5)  # a state change between periods (a restored or edited state)
    assert not ctl.at_rest()
    emu.step()
    assert not d.qd.any() and not np.signbit(d.qd).any()
    np.testing.assert_array_equal(d.qdd, (0.0 - 0.5) / dt * np.ones(6))
    assert not ctl.at_rest()
    emu.step()
    assert not (d.qdd.any() or np.signbit(d.qdd).any())
    assert ctl.at_rest()


def test_a_rest_period_keeps_its_arrays_until_something_replaces_them() -> None:
    emu = _at_rest_after_a_move()
    ctl = emu.controller
    d = ctl.data
    q, qd, qdd = d.q, d.qd, d.qdd
    emu.step()
    assert (d.q, d.qd, d.qdd) == (q, qd, qdd) and d.qd is qd and d.qdd is qdd
    d.qd = -np.zeros(6)  # equal to +0 but not +0: the reports' bytes would differ
    assert not ctl.at_rest()
    emu.step()
    assert not np.signbit(d.qd).any() and not np.signbit(d.qdd).any()
    assert ctl.at_rest()
    d.q = q + 0.001  # joints set from outside: a period that moves nothing keeps the speeds at +0
    emu.step()
    assert d.q is not q and not (d.qd.any() or np.signbit(d.qd).any())
    assert ctl.at_rest()


def test_an_error_at_rest_keeps_the_speeds_at_plus_zero() -> None:
    emu = _at_rest_after_a_move()
    ctl = emu.controller
    ctl.raise_error(11)
    emu.step(3)
    d = ctl.data
    assert not (d.qd.any() or d.qdd.any() or np.signbit(d.qd).any() or np.signbit(d.qdd).any())
