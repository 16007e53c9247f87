"""Where a recorded request can have been answered (server/placement.py): its window among the
real-time frames, from the proxy's clock, and the places (period, first frame after it) it leaves open."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.server import placement

#: Frames stamped every period from 0.1 s, each reaching the proxy 0.3 ms after its stamp plus 1 s.
TS = 0.1 + PERIOD * np.arange(10)
RECV = TS + 1.0003


def test_a_round_trip_between_two_frames_leaves_one_slot_and_two_periods() -> None:
    # request and reply between the frames stamped 0.108 and 0.112; the next frame comes 3.3 ms later
    (w,) = placement.windows(RECV, [(1.1090, 1.1094)])
    assert (w.first, w.last) == (3, 3)
    assert placement.candidates(TS, w, (0.0, 0)) == [(pytest.approx(0.108), 3), (pytest.approx(0.112), 3)]


def test_a_frame_right_after_the_reply_may_have_been_made_before_it() -> None:
    (w,) = placement.windows(RECV, [(1.1090, RECV[3] - 0.0005)])  # the reply 0.5 ms before the frame
    assert (w.first, w.last) == (3, 4)
    cands = placement.candidates(TS, w, (0.0, 0))
    assert [s for _, s in cands] == [3, 3, 4, 4]
    assert [round(t, 3) for t, _ in cands] == [0.108, 0.112, 0.112, 0.116]


def test_places_follow_the_command_before_and_missing_frames_open_more_periods() -> None:
    ts = np.delete(TS, [4, 5, 6])  # a box starved for three periods sent no frames for them
    recv = np.delete(RECV, [4, 5, 6])
    (w,) = placement.windows(recv, [(RECV[3] + 0.001, RECV[7] - 0.003)])
    cands = placement.candidates(ts, w, (0.116, 4))
    assert [round(t, 3) for t, _ in cands] == [0.116, 0.12, 0.124, 0.128]
    assert {s for _, s in cands} == {4}
    # the nearest to either estimate (the request's, the reply's) when there are too many
    many = [(0.1 + PERIOD * n, 1) for n in range(40)]
    kept = placement.nearest(many, (0.1, 0.1 + 39 * PERIOD))
    assert len(kept) == placement.MAX_TRIED and kept[0] == many[0] and kept[-1] == many[-1]


def test_undecided_windows() -> None:
    assert not placement.undecided(0.1, 0.1 + PERIOD)
    assert placement.undecided(0.1, 0.1 + 2 * PERIOD) and placement.undecided(0.1, float("inf"))


def test_run_to_steps_whole_periods_to_a_place_and_never_back(tmp_path: Path) -> None:
    """The one way compare and replay run the stepped emulator to what they re-run."""
    from xarm_emu.controller.emulator import Emulator
    from xarm_emu.server.core import EmulatorServer, ServerConfig

    server = EmulatorServer(Emulator(6, config_dir=tmp_path), ServerConfig(stepped=True, port=0))
    emu = server.emulator
    steps = emu.controller.data.steps
    placement.run_to(server, emu.time + 10 * PERIOD)
    assert emu.controller.data.steps == steps + 10
    placement.run_to(server, emu.time - 5 * PERIOD)  # a place already passed: now
    placement.run_to(server, emu.time + PERIOD / 4)  # less than half a period: no step
    assert emu.controller.data.steps == steps + 10
    placement.run_to(server, 0.0, period=steps + 25)  # after control period 25 (a trace's outside line)
    assert emu.controller.data.steps == steps + 25
    placement.run_to(server, 0.0, period=steps + 3)
    assert emu.controller.data.steps == steps + 25
