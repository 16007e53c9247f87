"""Trajectory recording, saving, loading and playback (registers 61-65, 230) in process, on the
stepped clock: a hand-guided motion in joint teaching mode is recorded, saved to the configuration
directory, loaded by a restarted box and played back through the recorded positions."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from helpers import bits
from test_fw2_motion import call, ready

from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import kinematics as kin

FW = "2.7.103"


def _emu(config: Path) -> Emulator:
    emu = Emulator(6, firmware=FW, config_dir=config)
    emu.controller.strict = True
    return emu


def hand_guided(t: float) -> np.ndarray:
    """A smooth motion as a hand would make it (rad)."""
    return np.array([0.4 * math.sin(1.5 * t), -0.3 * (1 - math.cos(t)), -0.2 * math.sin(t), 0.3 * t / 2,
                     0.5 * math.sin(0.8 * t), 0.0])


def record(emu: Emulator, seconds: float = 2.0) -> list[np.ndarray]:
    """Record a hand-guided motion in mode 2; returns the joint positions of every control period."""
    ctl = emu.controller
    ready(emu, mode=2)
    ctl.teach_move(hand_guided(0.0))
    assert call(emu, 61, on=1)[0] == 0
    seen = [ctl.q.copy()]
    for i in range(1, round(seconds / ctl.period) + 1):
        ctl.teach_move(hand_guided(i * ctl.period))
        emu.step()
        seen.append(ctl.q.copy())
    assert call(emu, 61, on=0)[0] == 0
    return seen


def test_recording_survives_a_restart_and_plays_back_through_the_recorded_points(tmp_path: Path) -> None:
    emu = _emu(tmp_path)
    recorded = record(emu)
    assert call(emu, 62, filename="wave.traj")[0] == 0
    assert call(emu, 65)[1] == {"status": 5}
    assert (tmp_path / "trajectories" / "wave.traj").is_file()

    box = _emu(tmp_path)  # a restart: a new box on the same configuration directory
    ready(box)
    ctl = box.controller
    assert call(box, 63, filename="wave.traj")[0] == 0
    assert call(box, 65)[1] == {"status": 2}
    assert call(box, 64, times=1, speed=1)[0] == 0
    assert ctl.mode == 11 and ctl.state == 1
    tcp = [ctl.tcp_matrix()[:3, 3].copy()]  # the lead-in ended on the first point
    while ctl.mode == 11:
        box.step()
        tcp.append(ctl.tcp_matrix()[:3, 3].copy())
    played = np.asarray(tcp)
    for q in recorded:
        want = kin.tcp_pose(ctl.model, q, ctl.settings.tcp_offset, ctl.settings.world_offset)[:3, 3]
        assert float(np.min(np.linalg.norm(played - want, axis=1))) < 0.1
    assert ctl.q == pytest.approx(recorded[-1], abs=1e-12)
    assert ctl.mode == 0 and ctl.state == 2


def test_playback_speed_is_the_recorded_speed_times_the_factor(tmp_path: Path) -> None:
    emu = _emu(tmp_path)
    recorded = record(emu, 2.0)
    call(emu, 62, filename="wave.traj")
    durations = {}
    for factor in (1, 2, 4):
        ready(emu)
        emu.controller.q = recorded[0].copy()
        call(emu, 63, filename="wave.traj")
        assert call(emu, 64, times=1, speed=factor)[0] == 0
        t0 = emu.controller.time
        while emu.controller.mode == 11:
            emu.step()
        durations[factor] = emu.controller.time - t0
    assert durations[1] == pytest.approx(2.0, abs=0.01)
    assert durations[2] == pytest.approx(1.0, abs=0.01)
    assert durations[4] == pytest.approx(0.5, abs=0.01)


def test_playback_first_moves_to_the_first_point(tmp_path: Path) -> None:
    emu = _emu(tmp_path)
    recorded = record(emu, 1.0)
    call(emu, 62, filename="a")
    ready(emu)
    emu.controller.q = np.zeros(6)
    call(emu, 63, filename="a")
    call(emu, 64, times=2, speed=1)
    steps = 0
    while emu.controller.mode == 11 and steps < 10000:
        emu.step()
        steps += 1
        assert float(np.max(np.abs(emu.controller.qd))) <= math.pi
    assert emu.controller.q == pytest.approx(recorded[-1], abs=1e-12)


def test_a_stop_ends_the_playback(tmp_path: Path) -> None:
    emu = _emu(tmp_path)
    record(emu, 1.0)
    call(emu, 62, filename="a")
    ready(emu)
    call(emu, 63, filename="a")
    call(emu, 64, times=-1, speed=1)
    emu.advance(3.0)
    assert emu.controller.mode == 11
    call(emu, 12, state=4)
    emu.step()
    assert emu.controller.mode == 0 and emu.controller.state == 4


@pytest.mark.parametrize("name", ["../escape.traj", "a/b.traj", "..", "x" * 81, "bad\x01name"])
def test_invalid_names_fail_to_save_and_to_load(tmp_path: Path, name: str) -> None:
    emu = _emu(tmp_path)
    record(emu, 0.1)
    state, _, _ = call(emu, 62, filename=name) if len(name) <= 81 else (0, {}, b"")
    if len(name) <= 81:
        assert not bits(state)[0] and call(emu, 65)[1] == {"status": 6}
    call(emu, 63, filename=name[:81])
    assert call(emu, 65)[1] == {"status": 3}
    assert not (tmp_path.parent / "escape.traj").exists()
    assert list((tmp_path / "trajectories").glob("*")) == [] if (tmp_path / "trajectories").exists() else True


def test_loading_a_missing_or_damaged_file_fails(tmp_path: Path) -> None:
    emu = _emu(tmp_path)
    call(emu, 63, filename="nothing.traj")
    assert call(emu, 65)[1] == {"status": 3}
    (tmp_path / "trajectories").mkdir()
    (tmp_path / "trajectories" / "junk.traj").write_bytes(b"\x00\x01 not json")
    call(emu, 63, filename="junk.traj")
    assert call(emu, 65)[1] == {"status": 3}


def test_playback_refusals(tmp_path: Path) -> None:
    emu = _emu(tmp_path)
    ready(emu)
    state, _, _ = call(emu, 64, times=1, speed=1)  # nothing loaded
    assert bits(state)[1] and emu.controller.mode == 0
    call(emu, 17)
    record(emu, 0.2)
    call(emu, 62, filename="a")
    ready(emu)
    call(emu, 63, filename="a")
    for times, speed in ((0, 1), (-2, 1), (1, 3)):
        call(emu, 17)
        state, _, _ = call(emu, 64, times=times, speed=speed)
        assert bits(state)[1] and emu.controller.warning_code == 12
    call(emu, 17)
    ready(emu, mode=4)
    state, _, _ = call(emu, 64, times=1, speed=1)
    assert bits(state)[2] and emu.controller.mode == 4


def test_register_230_checks_the_speed_of_the_loaded_trajectory(tmp_path: Path) -> None:
    emu = _emu(tmp_path)
    record(emu, 1.0)
    call(emu, 62, filename="a")
    call(emu, 63, filename="a")
    _, slow, _ = call(emu, 230, rate=1)
    assert slow["result"] == 0 and 0.5 < slow["speed"] < 0.7  # J1 peaks at 0.6 rad/s
    _, fast, _ = call(emu, 230, rate=4)
    assert fast["speed"] == pytest.approx(4 * slow["speed"], rel=1e-6)
    state, _, _ = call(emu, 230, rate=3)
    assert bits(state)[1]


def test_recording_stops_at_its_longest(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from xarm_emu.controller.applications import trajectory

    monkeypatch.setattr(trajectory, "MAX_RECORD_SECONDS", 0.2)
    emu = _emu(tmp_path)
    ready(emu, mode=2)
    call(emu, 61, on=1)
    emu.advance(1.0)
    assert len(trajectory.store_of(emu.controller).recorded) == round(0.2 / emu.controller.period) + 1


def _recording(emu: Emulator) -> RecordingFeedback:
    """Put a :class:`RecordingFeedback` in the place of ``emu``'s own feedback queue."""
    fb = RecordingFeedback()
    components = emu.controller.components
    components[components.index(emu.feedback)] = fb  # type: ignore[call-overload]
    return fb


class RecordingFeedback:
    """Stands in for the controller's feedback queue: records what trajectory tasks report."""

    def __init__(self) -> None:
        self.events: list[tuple[str, object, int, bool]] = []
        self.origin = 0

    def handlers(self) -> dict[int, object]:
        return {}

    def step(self, dt: float, ctl: object) -> None:
        pass

    def capture(self) -> object:
        self.origin += 1
        return ("request", self.origin)

    def start_other(self, origin: object, register: int, time_s: float, state: int = 0) -> bool:
        self.events.append(("start", origin, register, True))
        return True

    def finish_other(self, origin: object, register: int, time_s: float, *, ok: bool = True,
                     state: int = 0) -> bool:
        self.events.append(("finish", origin, register, ok))
        return True


def test_save_load_and_playback_report_other_start_and_finish_to_their_origin(tmp_path: Path) -> None:
    emu = _emu(tmp_path)
    fb = _recording(emu)
    record(emu, 0.5)
    call(emu, 62, filename="a")
    call(emu, 63, filename="missing")
    call(emu, 63, filename="a")
    ready(emu)
    call(emu, 64, times=1, speed=4)
    assert fb.events == [("start", ("request", 1), 62, True), ("finish", ("request", 1), 62, True),
                         ("start", ("request", 2), 63, True), ("finish", ("request", 2), 63, False),
                         ("start", ("request", 3), 63, True), ("finish", ("request", 3), 63, True),
                         ("start", ("request", 4), 64, True)]
    emu.advance(2.0)
    assert fb.events[-1] == ("finish", ("request", 4), 64, True)
    call(emu, 64, times=-1, speed=1)
    emu.advance(0.5)
    call(emu, 12, state=4)
    emu.step()
    assert fb.events[-1] == ("finish", ("request", 5), 64, False)


def test_leaving_mode_11_ends_the_playback_unfinished(tmp_path: Path) -> None:
    emu = _emu(tmp_path)
    fb = _recording(emu)
    record(emu, 0.5)
    call(emu, 62, filename="a")
    call(emu, 63, filename="a")
    ready(emu)
    call(emu, 64, times=-1, speed=1)
    emu.advance(0.3)
    call(emu, 19, mode=0)
    call(emu, 12, state=0)
    emu.advance(0.3)
    q = emu.controller.q.copy()
    emu.advance(0.3)
    assert fb.events[-1][0] == "finish" and fb.events[-1][2:] == (64, False)
    assert emu.controller.mode == 0 and emu.controller.q == pytest.approx(q, abs=1e-12)
