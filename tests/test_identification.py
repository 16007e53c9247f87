"""Load identification as a motion (register 204, the SDK's ``iden_tcp_load`` and
``ft_sensor_iden_load``): the wrist turns through the sequence at a wrist's pace, the rich report's
progress byte climbs to 100, the result comes from the readings taken, the arm ends where it
began, and a stop interrupts it."""

from __future__ import annotations

import struct
import threading
import time
from typing import Any

import numpy as np
import pytest
from helpers import sdk_ready

from xarm_emu.controller.applications import identification
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import STATE_NOT_READY

FW2 = "2.7.103"
MASS = 1.0
COM = (0.0, 0.0, 60.0)
SPEED = 10.0  # the server's clock runs ten times faster than the wall


def _server(make_server: Any, sensor: bool) -> Any:
    emu = Emulator(6, load_config=False, firmware=FW2, ft_sensor=sensor, ft_noise=False)
    emu.set_payload(MASS, COM)
    return make_server(emulator=emu, speed=SPEED)


def _watch(st: Any, stop: threading.Event) -> list[np.ndarray]:
    seen: list[np.ndarray] = []

    def run() -> None:
        while not stop.is_set():
            seen.append(np.array(st.call(lambda: st.emulator.controller.q.copy())))
            time.sleep(0.02)

    threading.Thread(target=run, daemon=True).start()
    return seen


@pytest.mark.parametrize("sensor", [False, True])
def test_identification_moves_reports_progress_and_returns(make_server: Any, sdk_arm: Any,
                                                           sensor: bool) -> None:
    st = _server(make_server, sensor)
    arm = sdk_arm(st, report_type="rich")
    sdk_ready(arm)
    assert arm.set_servo_angle(angle=[0, -20, -30, 0, 50, 0], speed=120, mvacc=1200, wait=True) == 0
    q0 = np.array(arm.get_servo_angle()[1][:6])
    progress: list[int] = []
    arm.register_iden_progress_changed_callback(lambda d: progress.append(d["progress"]))
    stop = threading.Event()
    seen = _watch(st, stop)
    t0 = st.call(lambda: st.emulator.time)
    if sensor:
        assert arm.set_ft_sensor_enable(1) == 0
        code, result = arm.ft_sensor_iden_load()
    else:
        code, result = arm.iden_tcp_load()
    t1 = st.call(lambda: st.emulator.time)
    stop.set()
    assert code == 0
    assert result[0] == pytest.approx(MASS, rel=0.03)  # the load below the sensor / on the flange
    moved = max(float(np.max(np.abs(np.degrees(q[:6]) - q0))) for q in seen)
    assert moved > 30.0  # the wrist turned during the call
    assert 10.0 < t1 - t0 < 40.0  # seconds of controller time, at a wrist's pace
    time.sleep(0.5)  # the last rich reports
    assert np.allclose(arm.get_servo_angle()[1][:6], q0, atol=0.01)
    rising = [p for i, p in enumerate(progress) if i == 0 or p > progress[i - 1]]
    assert rising == progress and len(progress) >= 5 and progress[-1] == 100, progress


def test_the_result_comes_from_the_readings_taken(tmp_path: Any) -> None:
    emu = Emulator(6, config_dir=tmp_path, firmware=FW2)
    emu.set_payload(MASS, COM)
    emu.handle(11, bytes([8, 1]))
    emu.handle(12, bytes([0]))
    state, _ = emu.handle(204, bytes([1]))
    assert not state & STATE_NOT_READY
    ctl = emu.controller
    iden = identification.of(ctl)
    assert iden is not None and iden.running and iden.progress == 0
    emu.set_payload(2 * MASS, COM)  # the load changes half way through: both show in the result
    while not identification.finished(ctl):
        emu.advance(0.5)
        if len(iden.samples) == 4:
            emu.set_payload(MASS, COM)
    assert iden.progress == 100 and len(iden.samples) == iden.readings
    assert MASS < iden.result[0] < 2 * MASS


def test_a_stop_interrupts_it(tmp_path: Any) -> None:
    emu = Emulator(6, config_dir=tmp_path, firmware=FW2)
    emu.handle(11, bytes([8, 1]))
    emu.handle(12, bytes([0]))
    emu.handle(204, bytes([1]))
    emu.advance(2.0)
    ctl = emu.controller
    assert not identification.finished(ctl)
    emu.handle(12, bytes([4]))  # stop
    emu.advance(0.5)
    assert identification.finished(ctl)
    assert identification.reply(ctl) == {"load": (0.0, 0.0, 0.0, 0.0)}
    assert identification.progress(ctl) < 100


def test_the_reply_waits_for_the_sequence_on_the_stepped_clock(make_server: Any, tmp_path: Any) -> None:
    import json

    from helpers import connect, recv_frame

    from xarm_emu.protocol.frame import encode_request

    emu = Emulator(6, load_config=False, firmware=FW2)
    emu.set_payload(MASS, COM)
    trace = tmp_path / "trace.jsonl"
    st = make_server(emulator=emu, stepped=True, admin=True, trace=trace)
    with connect(st.ports["command"]) as s:
        for tid, (reg, params) in enumerate(((11, bytes([8, 1])), (12, bytes([0]))), start=1):
            s.sendall(encode_request(tid, reg, params))
            recv_frame(s)
        s.sendall(encode_request(9, 204, bytes([1])))
        s.settimeout(0.3)
        with pytest.raises(TimeoutError):
            s.recv(64)
        st.call(lambda: st.server.advance(60.0))
        s.settimeout(2.0)
        frame = recv_frame(s)
    assert frame[:2] == struct.pack(">H", 9) and frame[6] == 204
    mass = struct.unpack_from("<f", frame, 8)[0]
    assert mass == pytest.approx(MASS, rel=0.03)
    st.stop()
    lines = [json.loads(x) for x in trace.read_text().splitlines()]
    iden = [x for x in lines if x.get("register") == 204]
    assert len(iden) == 1 and iden[0]["reply"] == frame[8:].hex() and iden[0]["t"] >= 10.0
    assert iden[0]["values"]["load"][0] == pytest.approx(MASS, rel=0.03)


def test_the_sequence_sends_no_task_feedback(tmp_path: Any) -> None:
    """The moves are the box's own: a connection whose register 254 mask asks for every task frame
    gets none for them (its wait is for the reply)."""
    from xarm_emu.controller.core.feedback import feedback_queue

    emu = Emulator(6, config_dir=tmp_path, firmware=FW2)
    ctl = emu.controller
    fb = feedback_queue(ctl)
    for tid, (reg, params) in enumerate(((11, bytes([8, 1])), (12, bytes([0])), (254, bytes([0xFF])),
                                         (204, bytes([1]))), start=1):
        fb.begin(ctl, 1, tid, 2, reg)
        state, _ = emu.handle(reg, params)
        fb.end(ctl, state)
    while not identification.finished(ctl):
        emu.advance(1.0)
    assert fb.drain() == []
    fb.begin(ctl, 1, 9, 2, 23)  # a move of the client's own still reports
    emu.handle(23, struct.pack("<7f3f", 0.1, 0, 0, 0, 0, 0, 0, 1.0, 10.0, 0.0))
    fb.end(ctl, 0)
    emu.advance(1.0)
    assert [e.feedback.register for e in fb.drain()] == [23, 23]


def test_replay_runs_a_traced_identification(make_server: Any, tmp_path: Any) -> None:
    from helpers import connect, recv_frame

    from xarm_emu.protocol.frame import encode_request
    from xarm_emu.replay import replay

    trace = tmp_path / "trace.jsonl"
    st = make_server(emulator=Emulator(6, load_config=False, firmware=FW2), stepped=True, admin=True,
                     trace=trace)
    with connect(st.ports["command"]) as s:
        for tid, (reg, params) in enumerate(((11, bytes([8, 1])), (12, bytes([0])), (204, bytes([1]))),
                                            start=1):
            s.sendall(encode_request(tid, reg, params))
            if reg == 204:  # held until the sequence has run
                s.settimeout(0.3)
                with pytest.raises(TimeoutError):
                    s.recv(64)
                st.call(lambda: st.server.advance(60.0))
                s.settimeout(2.0)
            recv_frame(s)
    st.stop()
    result = replay(trace, firmware=FW2)
    assert result.requests == 3 and result.differences == [], result.differences
