"""What lies inside an undecided window is never flagged: a recording without the real-time report
(port 30000) in which a move's round trip spans more than a control period and a second command
client's read overlaps it. The "real box" is an emulator on the stepped clock answering the read
before the move, the proxy's clock shows the read asked after the move: the recording cannot tell
which came first, so the read's differing reply is said (``inside``) and not counted. And the real-time
frames inside an undecided command's window are left out of the torque measures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.controller.emulator import Emulator
from xarm_emu.fidelity.compare import (
    DEFAULT_TOLERANCES,
    CommandResult,
    Comparison,
    Samples,
    Session,
    _measure,
    compare,
)
from xarm_emu.protocol import registers as regs
from xarm_emu.protocol.firmware import DEFAULT_PROFILE, SERVE_VERSION
from xarm_emu.protocol.frame import encode_request
from xarm_emu.server import xrec
from xarm_emu.server.core import EmulatorServer, ServerConfig

MOVE = 23  # move_joint (set_servo_angle, manual 2.1.3)


def _record(path: Path, tmp: Path, read_first: bool) -> None:
    """conn 1 the program, conn 2 a second client; the box answers each request at the controller
    time the proxy's clock gives (the first request at the first period), conn 2's get_state within
    the move's round trip, before the move when ``read_first``."""
    server = EmulatorServer(Emulator(6, config_dir=tmp, firmware=SERVE_VERSION),
                            ServerConfig(stepped=True, port=0))
    w = xrec.RecordWriter(path, "127.0.0.1", {30001: 30001})
    tid = {1: 0, 2: 0}

    def ask(conn: int, register: int, params: bytes = b"") -> tuple[int, bytes]:
        tid[conn] += 1
        return tid[conn], encode_request(tid[conn], register, params)

    def at(t: float) -> None:  # the box's clock: the proxy's, the first request at one period
        due = t + PERIOD - server.emulator.time
        if due > 1e-9:
            server.advance(due)

    def exchange(conn: int, t: float, register: int, params: bytes = b"", rtt: float = 0.001) -> None:
        n, frame = ask(conn, register, params)
        w.data(t, conn, xrec.COMMAND_PORT, xrec.TO_BOX, frame)
        at(t)
        w.data(t + rtt, conn, xrec.COMMAND_PORT, xrec.TO_PROGRAM, server.answer(n, 2, register, params))

    exchange(1, 0.0, 1)
    exchange(1, 0.01, 11, bytes([8, 1]))  # motion_enable
    exchange(1, 0.02, 19, bytes([0]))  # set_mode 0
    exchange(1, 0.03, 12, bytes([0]))  # set_state 0
    exchange(2, 0.04, 1)
    move = regs.get(MOVE).request.encode(joints=[0.3, -0.1, -0.05, 0, 0.15, 0, 0], speed=0.5, acc=5.0,
                                          mvtime=0.0)
    t_move, t_read = 0.5, 0.5 + PERIOD / 2  # the move's reply 3 periods after its request
    n_move, f_move = ask(1, MOVE, move)
    n_read, f_read = ask(2, 13)
    w.data(t_move, 1, xrec.COMMAND_PORT, xrec.TO_BOX, f_move)
    w.data(t_read, 2, xrec.COMMAND_PORT, xrec.TO_BOX, f_read)
    at(t_move + 2 * PERIOD)
    first = [(2, n_read, 13, b""), (1, n_move, MOVE, move)]
    order = first if read_first else first[::-1]
    replies = {conn: server.answer(n, 2, reg, p) for conn, n, reg, p in order}
    w.data(t_read + PERIOD, 2, xrec.COMMAND_PORT, xrec.TO_PROGRAM, replies[2])
    w.data(t_move + 3 * PERIOD, 1, xrec.COMMAND_PORT, xrec.TO_PROGRAM, replies[1])
    exchange(1, 2.0, 13)
    w.close()


def test_a_read_inside_an_undecided_window_is_not_flagged(tmp_path: Path) -> None:
    path = tmp_path / "overlap.xrec"
    _record(path, tmp_path / "box", read_first=True)
    r = compare(path)
    move = next(c for c in r.commands if c.register == MOVE)
    read = next(c for c in r.commands if c.register == 13 and c.t > move.t - 4 * PERIOD)
    assert move.undecided and move.placed_by == "clock" and move.window[1] - move.window[0] > PERIOD
    # the replay answers the read after the move (the recorded order): it differs, inside the window
    assert read.reply_differs and read.inside == move.index
    assert r.totals["reply_differences"] == 0 and r.totals["undecided_replies"] == 1
    assert r.failures == [] and r.to_json()["commands"][read.index]["inside"] == move.index


def test_the_same_read_after_the_move_compares_equal(tmp_path: Path) -> None:
    path = tmp_path / "ordered.xrec"
    _record(path, tmp_path / "box", read_first=False)
    r = compare(path)
    read = next(c for c in r.commands if c.register == 13 and c.inside is not None)
    assert not read.reply_differs  # answered as recorded: nothing to leave out
    assert r.totals["reply_differences"] == 0 and r.totals["undecided_replies"] == 0 and r.failures == []


def _frames(n: int, dof: int, torque_step: float) -> tuple[Samples, Samples]:
    """A recorded arm at rest for ``n`` periods and its replay, whose torques differ by
    ``torque_step`` at frames 5 to 7 (a payload change the replay placed a few periods off)."""
    rec = Samples.empty(n, dof)
    rec.t[:] = PERIOD * (1 + np.arange(n))
    rec.state[:] = 2
    rec.pos[:] = 200.0
    rec.torques[:], rec.currents[:] = 1.0, 0.1
    rep = Samples(*(np.copy(getattr(rec, f)) for f in ("t", "state", "joints", "pos", "torques", "currents",
                                                        "speeds")))
    rep.torques[5:8] += torque_step
    return rec, rep


@pytest.mark.parametrize("undecided", [True, False])
def test_frames_inside_an_undecided_window_are_left_out(undecided: bool) -> None:
    rec, rep = _frames(20, 6, 1.0)
    requests = [(xrec.Req(0.0, 1, b"", 1, 2, 1), xrec.Rep(0.001, 1, b"", 1, 2, 1, 0)),
                (xrec.Req(0.02, 1, b"", 2, 2, 17), xrec.Rep(0.03, 1, b"", 2, 2, 17, 0))]  # set_tcp_load
    session = Session("6,1", DEFAULT_PROFILE, requests, None, {})  # type: ignore[arg-type]
    r = Comparison("xarm6", "2.7.103", session=session, tolerances=dict(DEFAULT_TOLERANCES))
    r.recorded, r.replayed = rec, rep
    window = (float(rec.t[5]), float(rec.t[7]))
    r.commands = [CommandResult(0, PERIOD, 1, "GET_VERSION", placed_by="read"),
                  CommandResult(1, window[0], 17, "SET_LOAD_PARAM", window=window, placed_by="estimate",
                                undecided=undecided)]
    _measure(r, [(PERIOD, 0), (float(rec.t[5]), 5)], dict(DEFAULT_TOLERANCES), session, [])
    if undecided:  # the three frames of its window: not measured, said
        assert r.totals["torque_max"] == 0.0 and r.totals["excluded_frames"] == 3
        assert r.commands[1].excluded_frames == 3 and r.failures == []
    else:
        assert r.totals["torque_max"] == pytest.approx(1.0) and r.totals["excluded_frames"] == 0
        assert any(f.startswith("torque_max") for f in r.failures)


def test_the_page_does_not_count_a_reply_inside_a_window_among_the_worst(tmp_path: Path) -> None:
    from xarm_emu.fidelity.html_report import report_data

    path = tmp_path / "overlap.xrec"
    _record(path, tmp_path / "box", read_first=True)
    data = report_data(compare(path))
    assert data["worst"] == []  # the read's reply, inside the move's window, is not among what differs
    assert data["undecided"] and data["undecided"][0]["name"] == "MOVE_JOINT"
