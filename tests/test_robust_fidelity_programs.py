"""``make stress`` (XARM_EMU_STRESS=1): ``compare`` exact on the emulator itself over every program of the
library on its own, on every arm, and over random programs (hypothesis) made of the library's kinds of
steps: joint and linear moves, blends, payload, TCP and world offset changes, servo and velocity bursts,
the gripper and IO. Each is run by the unchanged SDK through the recording proxy with readers on every
report port and must compare with no difference. Skipped in ``make test`` (the bounded library is
tests/test_fidelity_programs.py)."""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import Any

import pytest
from fidelity_programs import PROGRAMS, record, recorded, wait_still
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xarm_emu.fidelity.compare import Comparison, compare
from xarm_emu.model.robots import ROBOT_MODELS

STRESS = os.environ.get("XARM_EMU_STRESS") == "1"
pytestmark = pytest.mark.skipif(not STRESS, reason="make stress (XARM_EMU_STRESS=1)")


def assert_equal(r: Comparison, missed: int) -> None:
    """No difference at all (a starved box's report rate aside: it sent fewer frames)."""
    failures = [f for f in r.failures if not (missed and f.startswith("report_rate_rel"))]
    differing = [(c.index, c.name, c.recorded_reply, c.replayed_reply) for c in r.commands if c.reply_differs]
    assert failures == [], (failures, differing)
    t = r.totals
    assert t["reply_differences"] == 0 and t["code_differences"] == 0 and t["duration_s"] == 0.0
    assert t["torque_max"] < 1e-3 and t["current_max"] < 1e-3 and t["path_mm"] < 1e-3


@pytest.mark.parametrize("name", list(PROGRAMS))
def test_each_program_alone(name: str, tmp_path: Path) -> None:
    missed = record(name, tmp_path / "p.xrec")
    assert_equal(compare(tmp_path / "p.xrec"), missed)


@pytest.mark.parametrize("model", [m for m in ROBOT_MODELS if m != "6"])
def test_first_program_on_every_arm(model: str, tmp_path: Path) -> None:
    missed = record("lite6", tmp_path / "p.xrec", model=model)
    assert_equal(compare(tmp_path / "p.xrec"), missed)


def _step(arm: Any, kind: str, x: float) -> None:
    """One step of a random program; ``x`` in [-1, 1] sizes it."""
    if kind == "joint":
        arm.set_servo_angle(angle=[15 * x, -10 * abs(x), -10, 0, 15, 10 * x], speed=150, wait=True)
    elif kind == "line":
        p = arm.get_position()[1]
        arm.set_position(x=p[0] + 25 * x, y=p[1] - 20 * x, z=p[2], roll=p[3], pitch=p[4], yaw=p[5],
                         speed=300, wait=True)
    elif kind == "blend":
        p = arm.get_position()[1]
        for dx, dy in ((30, 0), (30, 30 * x), (0, 0)):
            arm.set_position(x=p[0] + dx, y=p[1] + dy, z=p[2], roll=p[3], pitch=p[4], yaw=p[5], speed=400,
                             radius=10 + 10 * abs(x), wait=False)
        wait_still(arm)
    elif kind == "payload":
        arm.set_tcp_load(1.0 + abs(x), [0, 0, 40 * abs(x)])
        arm.set_state(0)
    elif kind == "tcp":
        arm.set_tcp_offset([0, 0, 40 * abs(x), 0, 0, 0])
        arm.set_state(0)
    elif kind == "world":
        arm.set_world_offset([0, 0, 0, 0, 0, 10 * x])
        arm.set_state(0)
    elif kind == "servo":
        arm.set_mode(1)
        arm.set_state(0)
        time.sleep(0.05)
        q = arm.get_servo_angle()[1][:6]
        for k in range(15):
            arm.set_servo_angle_j([q[0] + 0.1 * k * x, *q[1:6]])
            time.sleep(0.01)
        arm.set_mode(0)
        arm.set_state(0)
    elif kind == "velocity":
        arm.set_mode(4)
        arm.set_state(0)
        time.sleep(0.05)
        arm.vc_set_joint_velocity([15 * x, 0, 0, 0, 0, 0])
        time.sleep(0.15)
        arm.vc_set_joint_velocity([0, 0, 0, 0, 0, 0])
        time.sleep(0.05)
        arm.set_mode(0)
        arm.set_state(0)
    elif kind == "io":
        arm.set_cgpio_digital(int(abs(x) * 7), 1)
        arm.get_cgpio_state()
    elif kind == "gripper":
        arm.set_gripper_enable(True)
        arm.set_gripper_position(int(400 + 300 * x), wait=False)


KINDS = ("joint", "line", "blend", "payload", "tcp", "world", "servo", "velocity", "io", "gripper")


@settings(max_examples=12, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.lists(st.tuples(st.sampled_from(KINDS), st.floats(-1, 1)), min_size=2, max_size=6))
def test_random_programs(steps: list[tuple[str, float]]) -> None:
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "random.xrec"
        with recorded(path) as (server, arm):
            for kind, x in steps:
                _step(arm, kind, x)
            wait_still(arm)
            missed = sum(server.server.reports.frames_missed.values())
        assert_equal(compare(path), missed)
