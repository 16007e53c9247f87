"""The linear track on the control box RS-485 (register 124, host 11, slave 1) driven by the frames
the SDK sends, under the stepped clock: homing, the trapezoidal move and its timing, stop, the
drive's errors, checkpoints, the bus baud, and the CLI, fleet and admin faces."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import pytest
from helpers import run_cli as run

from xarm_emu import cli
from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.controller.devices.linear_track import HOME_LATCH, LinearTrack, plan_move
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import rtu
from xarm_emu.protocol.firmware import SERVE_VERSION
from xarm_emu.server.admin import AdminError, prepare
from xarm_emu.server.fleet import FleetError, parse_fleet


def send(emu: Emulator, pdu: bytes) -> bytes:
    """Register 124 to host 11 as the SDK frames it; the RTU reply without the host byte."""
    state, out = emu.handle(124, bytes([rtu.CONTROL_BOX_HOST]) + pdu)
    assert out[0] == rtu.CONTROL_BOX_HOST and not state & 0x20  # never a warning (no refusal)
    return out[1:]


def read(emu: Emulator, addr: int, count: int = 1) -> tuple[int, ...]:
    slave, func, values = rtu.parse_reply(send(emu, rtu.read_request(1, addr, count)))
    assert (slave, func) == (1, rtu.READ_HOLDING)
    return values


def write(emu: Emulator, addr: int, *words: int) -> bytes:
    return send(emu, rtu.write_multiple_request(1, addr, words))


def position_mm(emu: Emulator) -> float:
    hi, lo = read(emu, 0x0A20, 2)
    return struct.unpack(">i", struct.pack(">HH", hi, lo))[0] / 2000


def set_target(emu: Emulator, mm: float) -> bytes:
    # The SDK's frame: 01 10 0700 0002 04 <s32 BE of mm x 2000>.
    return send(emu, bytes.fromhex("01 10 07 00 00 02 04") + struct.pack(">i", int(mm * 2000)))


def steps_until(emu: Emulator, done, limit: float = 20.0) -> float:  # type: ignore[no-untyped-def]
    t0 = emu.time
    while not done():
        assert emu.time - t0 < limit, "never finished"
        emu.step()
    return emu.time - t0


def homed(length: int = 700, start: float = 0.0) -> Emulator:
    emu = Emulator(6, firmware=SERVE_VERSION, linear_track=length)
    assert emu.linear_track is not None
    emu.linear_track.position = emu.linear_track.target = start
    # Back to origin is a write single register (0x06) of 1 at 0x0A0A, as the SDK sends it.
    assert send(emu, bytes.fromhex("01 06 0A 0A 00 01")) == bytes.fromhex("01 06 0A 0A 00 01")
    steps_until(emu, lambda: read(emu, 0x0A25)[0] == 1)
    return emu


def test_power_on_registers_as_the_sdk_reads_them() -> None:
    emu = Emulator(6, firmware=SERVE_VERSION, linear_track=1000)
    # pos (2 words), status, error, enabled, on zero, SCI (bit 1 high), SCO
    assert read(emu, 0x0A20, 8) == (0, 0, 0, 0, 0, 0, 2, 0)
    assert read(emu, 0x0303) == (5000,)  # 750 mm/s in the speed register's units
    sn = "".join(chr(c) for c in read(emu, 0x0B10, 14))
    assert len(sn) == 14 and sn.startswith("AL1301")


def test_homing_duration_and_state() -> None:
    emu = Emulator(6, firmware=SERVE_VERSION, linear_track=700)
    track = emu.linear_track
    assert track is not None
    track.position = track.target = 230.0
    send(emu, rtu.write_single_request(1, 0x0A0A, 1))
    # homing powers the drive and moves: enabled, moving, not yet on zero
    assert read(emu, 0x0A22, 4) == (1, 0, 1, 0)
    took = steps_until(emu, lambda: read(emu, 0x0A25)[0] == 1)
    speed, acc = 1533 / 6.667, 1000 / 0.3  # homing speed and acceleration (linear_track.py)
    expected = 230.0 / speed + speed / acc + HOME_LATCH
    assert took == pytest.approx(expected, abs=2 * PERIOD)
    assert position_mm(emu) == 0.0 and read(emu, 0x0A22)[0] == 0


def test_move_follows_the_trapezoid_and_arrives_on_time() -> None:
    emu = homed()
    write(emu, 0x0303, int(500 * 6.667))
    assert set_target(emu, 300) == bytes.fromhex("01 10 07 00 00 02")
    v, a = int(500 * 6.667) / 6.667, 1000 / 0.3
    expected = 300 / v + v / a  # 0.750 s: 0.15 s ramps at 3333 mm/s^2, cruise at 500 mm/s
    samples = []
    took = steps_until(emu, lambda: samples.append(position_mm(emu)) or read(emu, 0x0A22)[0] & 1 == 0)
    assert took == pytest.approx(expected, abs=PERIOD)
    assert position_mm(emu) == 300.0
    speeds = [(b - a) / PERIOD for a, b in zip(samples, samples[1:], strict=False)]
    assert max(speeds) == pytest.approx(v, rel=0.01)
    assert all(s >= -1e-6 for s in speeds)  # never backwards
    # half way through the acceleration ramp the carriage covered a t^2 / 2
    assert samples[round(0.075 / PERIOD)] == pytest.approx(0.5 * a * 0.075 ** 2, abs=0.6)


def test_retarget_and_stop_blend_without_a_jump() -> None:
    emu = homed()
    set_target(emu, 600)
    emu.advance(0.5)
    track = emu.linear_track
    assert track is not None
    v_before = track.velocity
    set_target(emu, 100)  # reverse mid-move: brake first, then come back
    emu.step()
    assert abs(track.velocity - v_before) <= 1000 / 0.3 * PERIOD + 1e-6
    steps_until(emu, lambda: not track.moving)
    assert position_mm(emu) == 100.0
    set_target(emu, 500)
    emu.advance(0.3)
    x, v = track.position, track.velocity
    write(emu, 0x0A0E, 1)  # stop
    steps_until(emu, lambda: not track.moving)
    assert track.position == pytest.approx(x + v * v / (2 * 1000 / 0.3), abs=1e-6)
    assert read(emu, 0x0A22)[0] == 2  # at rest, stopped by the stop command


@pytest.mark.parametrize("x, v, goal", [(0, 0, 300), (100, 400, 50), (500, -200, 600), (10, 900, 20)])
def test_plan_ends_at_rest_on_the_goal_within_limits(x: float, v: float, goal: float) -> None:
    acc = dec = 1000 / 0.3
    phases = plan_move(x, v, goal, 500.0, acc, dec)
    duration, x0, v0, a = phases[-1]
    assert x0 + v0 * duration + 0.5 * a * duration ** 2 == pytest.approx(goal, abs=1e-6)
    assert v0 + a * duration == pytest.approx(0.0, abs=1e-6)
    assert all(abs(p[3]) <= acc + 1e-9 for p in phases)
    assert all(abs(p[2]) <= max(500.0, abs(v)) + 1e-6 for p in phases)


@pytest.mark.parametrize("action, error", [
    (lambda emu: set_target(emu, 701), 25),  # beyond the 700 mm stroke: command over software limit
    (lambda emu: set_target(emu, -1), 25),
    (lambda emu: write(emu, 0x0303, int(1001 * 6.667)), 12),  # above 1000 mm/s: speed overlimit
    (lambda emu: write(emu, 0x0303, 0), 12),
    (lambda emu: (write(emu, 0x0100, 0), set_target(emu, 100)), 13),  # target while disabled
])
def test_bad_commands_raise_the_drive_error_and_disable(action, error: int) -> None:  # type: ignore[no-untyped-def]
    emu = homed()
    action(emu)
    assert read(emu, 0x0A23, 2) == (error, 0)  # error, drive disabled
    emu.advance(0.5)
    assert position_mm(emu) == 0.0
    write(emu, 0x0100, 1)
    assert read(emu, 0x0A24)[0] == 0  # an error keeps the drive off
    write(emu, 0x0109, 1)
    write(emu, 0x0100, 1)
    assert read(emu, 0x0A23, 2) == (0, 1)


def test_target_before_homing_is_ignored_and_estop_cuts_the_drive() -> None:
    emu = Emulator(6, firmware=SERVE_VERSION, linear_track=700)
    write(emu, 0x0100, 1)
    set_target(emu, 200)
    emu.advance(0.5)
    assert position_mm(emu) == 0.0 and read(emu, 0x0A22, 2) == (0, 0)
    emu = homed()
    set_target(emu, 400)
    emu.advance(0.2)
    emu.inject_estop()
    emu.step()
    at = position_mm(emu)
    emu.advance(0.5)
    assert position_mm(emu) == at and read(emu, 0x0A24, 2) == (0, 1)  # disabled, still homed


def test_checkpoint_holds_the_carriage() -> None:
    emu = homed()
    set_target(emu, 500)
    emu.advance(0.3)
    cp = emu.checkpoint()
    emu.advance(1.0)
    end = position_mm(emu)
    emu.restore(cp)
    mid = position_mm(emu)
    assert 0 < mid < end == 500.0
    emu.advance(1.0)
    assert position_mm(emu) == end


def test_the_bus_baud_and_a_box_without_a_track() -> None:
    emu = homed()
    emu.io.tool.baud_index[rtu.CONTROL_BOX_HOST] = 5  # the box bus at another baud: no answer
    assert send(emu, rtu.read_request(1, 0x0A20, 2)) == bytes((1, 0x83, rtu.GATEWAY_NO_RESPONSE))
    bare = Emulator(6)
    assert bare.linear_track is None
    assert send(bare, rtu.read_request(1, 0x0A20, 2)) == bytes((1, 0x83, rtu.GATEWAY_NO_RESPONSE))
    with pytest.raises(ValueError, match="no linear track"):
        bare.inject_track_error(12)
    with pytest.raises(ValueError, match="firmware 1.8.0 or later"):
        Emulator(6, linear_track=700)  # the manual's box, 1.6.0


def test_unknown_registers_and_lengths_are_refused() -> None:
    emu = homed()
    assert send(emu, rtu.read_request(1, 0x0A28, 1)) == bytes((1, 0x83, rtu.ILLEGAL_ADDRESS))
    assert write(emu, 0x0A20, 5) == bytes((1, 0x90, rtu.ILLEGAL_ADDRESS))
    with pytest.raises(ValueError, match="700, 1000, 1500"):
        LinearTrack(800)
    with pytest.raises(ValueError, match="one of"):
        LinearTrack(700).inject_error(99)


def test_parameters_are_stored_and_read_back() -> None:
    emu = homed()
    write(emu, 0x1300, 600, 600)  # acceleration and deceleration times, ms
    assert read(emu, 0x1300, 2) == (600, 600)
    write(emu, 0x0303, int(1000 * 6.667))
    set_target(emu, 600)
    took = steps_until(emu, lambda: read(emu, 0x0A22)[0] & 1 == 0)
    v, a = int(1000 * 6.667) / 6.667, 1000 / 0.6
    assert took == pytest.approx(600 / v + v / a, abs=PERIOD)
    assert not math.isnan(position_mm(emu))


# --- faces: serve, fleet, admin ----------------------------------------------------------------------


def test_serve_option_and_fleet_key(tmp_path: Path) -> None:
    assert cli.bare_linear_track(["--linear-track"]) == ["--linear-track=700"]
    assert cli.bare_linear_track(["--linear-track", "--admin"]) == ["--linear-track=700", "--admin"]
    assert cli.bare_linear_track(["--linear-track", "1500"]) == ["--linear-track", "1500"]
    code, out = run("serve", "--linear-track", "800", "--port", "0")
    assert code == 2 and "--linear-track" in out and "700, 1000, 1500" in out
    code, out = run("serve", "--firmware", "1.6.0", "--linear-track", "--port", "0")
    assert code == 2 and "needs firmware 1.8.0 or later" in out
    free = {"port": 0, "normal_port": 0, "rich_port": 0, "develop_port": 0}
    fleet = parse_fleet({"arm": [{"linear_track": True, **free}, {"linear_track": 1500, **free}, free]})
    assert [a.linear_track for a in fleet.arms] == [700, 1500, None]
    with pytest.raises(FleetError, match="linear_track"):
        parse_fleet({"arm": [{"linear_track": 900}]})


class _Target:
    def __init__(self, emu: Emulator) -> None:
        self.emulator = emu


def test_admin_track_error() -> None:
    emu = homed()
    message = prepare(_Target(emu), {"cmd": "track-error", "code": 33})()  # type: ignore[arg-type]
    assert "33" in message and read(emu, 0x0A23)[0] == 33
    with pytest.raises(AdminError, match="one of"):
        prepare(_Target(emu), {"cmd": "track-error", "code": 7})  # type: ignore[arg-type]
    with pytest.raises(AdminError, match="no linear track"):
        prepare(_Target(Emulator(6)), {"cmd": "track-error", "code": 12})  # type: ignore[arg-type]
    emu.clear_faults()
    assert read(emu, 0x0A23)[0] == 0


# --- the 3D view ----------------------------------------------------------------------------------


def test_rail_slides_under_the_carriage() -> None:
    from xarm_emu.viewer import scene

    rail, carriage = scene.track_parts(1000, 0.0)
    assert carriage.position[:2] == (0.0, 0.0) and carriage.position[2] < 0.0  # right under the base
    assert rail.half[1] == pytest.approx(0.5) and rail.position[1] == pytest.approx(0.5)
    rail2, carriage2 = scene.track_parts(1000, 300.0)
    assert rail2.position[1] - rail.position[1] == pytest.approx(-0.3)  # the rail moved 300 mm back
    assert carriage2 == carriage
    # the carriage sits on the rail, the base on the carriage
    top_of_rail = rail.position[2] + rail.half[2]
    assert top_of_rail == pytest.approx(carriage.position[2] - carriage.half[2])
    assert carriage.position[2] + carriage.half[2] == pytest.approx(0.0)


def test_the_view_draws_the_track(make_server, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    pytest.importorskip("viser")
    from helpers import wait_for

    emu = Emulator(6, firmware=SERVE_VERSION, linear_track=700, config_dir=tmp_path)
    st = make_server(view=True, view_port=0, emulator=emu)
    viewer = st.server.viewer
    assert wait_for(lambda: {"/track/track_rail", "/track/track_carriage"} <= set(viewer._handles))
    st.call(lambda: setattr(emu.linear_track, "position", 350.0))
    assert wait_for(lambda: abs(viewer._handles["/track/track_rail"].position[1]) < 1e-9)


def test_fault_schedule_raises_the_track_error_on_time(tmp_path: Path) -> None:
    from xarm_emu.server.faults import FaultScheduleError, read_schedule, schedule

    path = tmp_path / "faults.toml"
    emu = homed()
    t0 = emu.time  # `at` counts controller time from the start
    path.write_text(f'[[fault]]\nat = {t0 + 0.5:.3f}\ndo = "track-error"\ncode = 34\n')
    assert schedule(_Target(emu), read_schedule(path)) == 1  # type: ignore[arg-type]
    set_target(emu, 600)
    steps_until(emu, lambda: read(emu, 0x0A23)[0] == 34)
    assert emu.time - t0 == pytest.approx(0.5, abs=PERIOD)
    assert read(emu, 0x0A22)[0] & 1 == 0  # the fault stopped the carriage
    with pytest.raises(FaultScheduleError, match="no linear track"):
        schedule(_Target(Emulator(6)), read_schedule(path))  # type: ignore[arg-type]


def test_jump_over_idle_periods_leaves_the_track_as_stepping_every_period() -> None:
    """Homing, a move, rest: the emulator's jump over idle periods (controller/emulator.py) gives the
    carriage the same position, speed and state at every instant as stepping period by period, and
    it does jump while the carriage rests."""
    fast = Emulator(6, firmware=SERVE_VERSION, linear_track=1000)
    exact = Emulator(6, firmware=SERVE_VERSION, linear_track=1000, exact_steps=True)
    script = [(0, lambda e: send(e, bytes.fromhex("01 06 0A 0A 00 01"))),
              (1200, lambda e: set_target(e, 420.5)), (2500, lambda e: set_target(e, 10.0))]
    done = 0
    for stride in [7, 1, 50, 3, 400] * 10:
        while script and script[0][0] <= done:  # each action at the first instant at or after its period
            for emu in (fast, exact):
                script[0][1](emu)
            script.pop(0)
        for emu in (fast, exact):
            emu.step(stride)
        done += stride
        seen = [(read(e, 0x0A20, 2), read(e, 0x0A22), read(e, 0x0A25), e.time.hex()) for e in (fast, exact)]
        assert seen[0] == seen[1], f"differ after period {done}"
    assert not script
    assert fast.periods_jumped > 0.3 * fast.controller.steps and exact.periods_jumped == 0
    assert position_mm(fast) == pytest.approx(10.0)
