"""A Cartesian plan samples its path for the next control periods at once while the path rate is
steady (controller/core/executor.py ``_CartesianPlan.sample``): every period still puts the TCP on the
path at its own path time, whatever happens to the rate (suspend and resume, register 12 state 3;
a stop, state 4), with TCP and user coordinate offsets (registers 35, 73), along lines, blended
lines (22) and circles (27)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from helpers import ready

from xarm_emu.controller.core import executor as ex
from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import kinematics as kin
from xarm_emu.model import rotations as rot

PI = math.pi
#: TCP position against the path's own pose at the period's path time (mm): the solver's tolerance
#: (1e-6 mm at the flange) and its rotation tolerance (1e-7 rad) times the TCP offset's length.
POS_TOL = 1e-4
ROT_TOL = 1e-6  # rad


def send(emu: Emulator, code: int, **values: Any) -> int:
    reg = emu.controller.registers[code]
    return emu.handle(code, reg.request.encode(values))[0]


def program(emu: Emulator, offsets: bool) -> None:
    ready(emu)
    if offsets:
        send(emu, 35, pose=(10.0, -5.0, 80.0, 0.1, 0.0, 0.2))
        send(emu, 73, pose=(20.0, 30.0, 0.0, 0.0, 0.0, 0.3))
        ready(emu)  # the offsets reset the box (section 1.5)
    send(emu, 23, joints=(0.4, 0.1, -0.3, 0.0, 0.2, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0)
    send(emu, 22, pose=(300.0, 50.0, 200.0, PI, 0.0, 0.0), speed=150.0, acc=2000.0, mvtime=0.0, radius=20.0)
    send(emu, 21, pose=(300.0, -50.0, 220.0, PI, 0.1, 0.0), speed=150.0, acc=2000.0, mvtime=0.0)
    send(emu, 27, pose1=(330.0, 0.0, 200.0, PI, 0.0, 0.0), pose2=(300.0, 50.0, 230.0, PI, 0.0, 0.0),
         speed=150.0, acc=2000.0, mvtime=0.0, percent=120.0)
    send(emu, 21, pose=(250.0, 0.0, 250.0, PI, 0.0, 0.0), speed=150.0, acc=2000.0, mvtime=0.0)


def follow(emu: Emulator, seconds: float, events: dict[float, int]) -> tuple[int, int]:
    """Step period by period for ``seconds``, register 12 set to each ``events`` state at its time;
    after each Cartesian period the TCP pose is checked against the plan's path at the path time.
    Returns (Cartesian periods checked, periods sampled from a batch)."""
    ctl = emu.controller
    checked = batched = 0
    pending = sorted(events.items())
    while ctl.data.time < seconds:
        if pending and ctl.data.time >= pending[0][0]:
            send(emu, 12, state=pending.pop(0)[1])
        emu.step(1)
        plan = ctl.data.motion.plan
        if not isinstance(plan, ex._CartesianPlan) or ctl.data.motion.t >= plan.duration:
            continue
        t = ctl.data.motion.t
        b, i = plan._batch, plan._next
        batched += b is not None and i > 1 and b[0][i - 1] == t
        want = plan.move.at(t)[0]
        got = ctl.tcp_matrix()
        assert np.linalg.norm(got[:3, 3] - want[:3, 3]) <= POS_TOL, (ctl.data.time, t)
        assert np.linalg.norm(rot.matrix_to_axis_angle(got[:3, :3] @ want[:3, :3].T)) <= ROT_TOL
        checked += 1
    assert ctl.error_code == 0
    return checked, batched


@pytest.mark.parametrize("offsets", [False, True])
def test_every_period_is_on_the_path_at_its_own_path_time(offsets: bool) -> None:
    emu = Emulator(6)
    program(emu, offsets)
    checked, batched = follow(emu, 20.0, {})
    assert checked > 1000 and batched > 0.9 * checked  # nearly all periods from batches
    assert not emu.controller.is_moving


def test_suspend_resume_and_stop_keep_the_path_time() -> None:
    """The rate ramps of suspend (3), resume (0) and stop (4) change the path time's steps: each
    period then samples its own time, and a steady rate again samples in batches."""
    emu = Emulator(6)
    program(emu, False)
    checked, batched = follow(emu, 12.0, {3.0: 3, 3.7: 0, 5.1: 3, 5.2: 0, 9.0: 4})
    assert checked > 1000 and 0.5 * checked < batched < checked
    assert not emu.controller.is_moving and emu.controller.executor.cmdnum == 0


def test_the_same_joints_whether_sampled_in_batches_or_one_by_one(monkeypatch: pytest.MonkeyPatch) -> None:
    """Batched samples are the path's own poses: joints along the program agree with a run that
    samples every period alone to far below the solver's tolerance."""
    def run() -> list[np.ndarray]:
        emu = Emulator(6)
        program(emu, True)
        out = []
        for _ in range(3000):
            emu.step(1)
            out.append(emu.controller.q.copy())
        return out

    batched = run()
    monkeypatch.setattr(ex, "SAMPLE_BATCH", 1)
    alone = run()
    assert max(float(np.abs(a - b).max()) for a, b in zip(batched, alone, strict=True)) < 1e-9
    model = Emulator(6).controller.model  # and the program moved the flange
    assert np.linalg.norm(kin.fk(model, batched[-1])[:3, 3] - kin.fk(model, batched[500])[:3, 3]) > 10.0
