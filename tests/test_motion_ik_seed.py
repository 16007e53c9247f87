"""The Cartesian plan's IK seed (controller/core/executor.py): each control period of a linear move
(register 21) and an arc (register 27) starts the solver from the extrapolation of the last answers
(the chord solve of kinematics.track, the full solve where it does not converge); the joints it
reaches put the flange on the path within the solver's convergence tolerance (|dp| <= 1e-6 mm,
|d theta| <= 1e-7 rad), agree with a solve from the previous joints alone, need fewer iterations of
the full solver than that solve, and a pose out of reach still gives no solution (C21)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from xarm_emu.controller.core import executor as ex
from xarm_emu.controller.core.interface import C_KINEMATIC
from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import kinematics as kin
from xarm_emu.model.rotations import matrix_to_axis_angle

PI = math.pi


def send(emu: Emulator, code: int, **values: Any) -> int:
    reg = emu.controller.registers[code]
    return emu.handle(code, reg.request.encode(values))[0]


def ready(emu: Emulator) -> None:
    send(emu, 11, joint=8, enable=1)
    send(emu, 19, mode=0)
    send(emu, 12, state=0)


def count_iterations(monkeypatch: pytest.MonkeyPatch, model: Any) -> list[int]:
    """Wrap the model's unrolled solver so that its iterations (its first answer) are summed."""
    fn = kin._chain_fn(model, "lm")
    total = [0]

    def counted(*args: float) -> tuple[float, ...]:
        r = fn(*args)
        total[0] += int(r[0])
        return r

    monkeypatch.setitem(kin._CACHE, id(model), (model, {**kin._CACHE[id(model)][1], "lm": counted}))
    return total


MOVES = {
    "line": (21, {"pose": (300.0, -80.0, 180.0, PI, 0.2, 0.3), "speed": 150.0, "acc": 2000.0, "mvtime": 0.0}),
    "arc": (27, {"pose1": (330.0, 0.0, 200.0, PI, 0.0, 0.0), "pose2": (300.0, 50.0, 230.0, PI, 0.0, 0.0),
                 "speed": 150.0, "acc": 2000.0, "mvtime": 0.0, "percent": 120.0}),
}


@pytest.mark.parametrize("name", sorted(MOVES))
def test_extrapolated_seed_stays_on_the_path(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    emu = Emulator(6)
    ready(emu)
    ctl = emu.controller
    assert send(emu, 21, pose=(300.0, 50.0, 200.0, PI, 0.0, 0.0), speed=150.0, acc=2000.0, mvtime=0.0) == 0
    emu.advance(3.0)
    assert not ctl.is_moving
    code, values = MOVES[name]
    assert send(emu, code, **values) == 0
    calls = count_iterations(monkeypatch, ctl.model)
    periods = 0
    solves = 0
    while True:
        q_prev = ctl.q.copy()
        emu.step(1)
        plan = ctl.executor.data.plan
        if plan is None:
            break
        assert isinstance(plan, ex._CartesianPlan)
        t = min(ctl.executor.data.t, plan.duration)
        target = plan.to_flange(plan.move.at(t)[0])
        T = kin.fk(ctl.model, ctl.q)
        assert float(np.linalg.norm(T[:3, 3] - target[:3, 3])) <= kin.POS_TOL
        assert float(np.linalg.norm(matrix_to_axis_angle(target[:3, :3] @ T[:3, :3].T))) <= kin.ROT_TOL
        before = calls[0]
        plain = kin.ik(ctl.model, target, q_prev, limited=False)
        solves += calls[0] - before
        assert plain is not None
        np.testing.assert_allclose(ctl.q[: ctl.model.dof], plain, atol=1e-8)
        periods += 1
    assert periods > 100
    # the extrapolated start needs fewer solver iterations than the previous joints alone
    assert calls[0] - solves < 0.8 * solves


def test_unreachable_pose_along_the_path_still_fails() -> None:
    emu = Emulator(6)
    ready(emu)
    ctl = emu.controller
    assert send(emu, 21, pose=(400.0, 0.0, 200.0, PI, 0.0, 0.0), speed=150.0, acc=2000.0, mvtime=0.0) == 0
    emu.step(10)
    plan = ctl.executor.data.plan
    assert isinstance(plan, ex._CartesianPlan)
    reach = plan.to_flange

    def out_of_reach_after(T: np.ndarray) -> np.ndarray:
        T = reach(T)
        if T[0, 3] > 250.0:
            T = T.copy()
            T[0, 3] += 2000.0
        return T

    plan.to_flange = out_of_reach_after
    for _ in range(2000):
        q_prev = ctl.q.copy()
        t_next = ctl.executor.data.t + ctl.period
        emu.step(1)
        if ctl.executor.data.plan is None:
            break
    else:
        raise AssertionError("the move never reached the unreachable part")
    target = out_of_reach_after(plan.move.at(min(t_next, plan.duration))[0])
    assert kin.ik(ctl.model, target, q_prev, limited=False) is None
    assert ctl.error_code == C_KINEMATIC
    np.testing.assert_allclose(ctl.q, q_prev)
