"""Test helpers: encode requests and decode replies through the register table; free ports and
`xarm-emu serve` in a child process."""

from __future__ import annotations

import contextlib
import itertools
import math
import os
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from xarm_emu.controller.emulator import Emulator
from xarm_emu.model.kinematics import fk, ik, within_limits
from xarm_emu.model.robots import RobotModel
from xarm_emu.model.rotations import matrix_to_axis_angle
from xarm_emu.protocol.frame import STATE_ERROR, STATE_NOT_READY, STATE_WARNING
from xarm_emu.protocol.registers import REGISTERS
from xarm_emu.protocol.reports import encoders_for


def assert_ik_round_trips(model: RobotModel,
                          draw: Callable[[RobotModel, np.random.Generator], np.ndarray]) -> None:
    """Solve IK for the poses of 40 joint sets ``draw`` gives, from a start 0.2 rad off: at least 39
    are solved, within the limits, and their FK is the pose within 1e-3 mm and 1e-5 rad."""
    rng = np.random.default_rng(3)
    solved = 0
    for _ in range(40):
        truth = draw(model, rng)
        T = fk(model, truth)
        q = ik(model, T, truth + rng.uniform(-0.2, 0.2, model.dof))
        if q is None:
            continue
        solved += 1
        assert within_limits(model, q)
        Tq = fk(model, q)
        assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 1e-3
        assert np.linalg.norm(matrix_to_axis_angle(Tq[:3, :3] @ T[:3, :3].T)) < 1e-5
    assert solved >= 39


def call(emu: Emulator, code: int, **values: Any) -> tuple[int, dict[str, Any]]:
    """Send one command to an in-process emulator; returns (state byte, reply values)."""
    reg = REGISTERS[code]
    state, reply = emu.handle(code, reg.request.encode(values))
    decoded = reg.reply.decode(reply) if reply or reg.reply.fields else {}
    return state, decoded


def ready(emu: Emulator) -> None:
    """The SDK's start sequence: enable all joints, position mode, ready state."""
    for code, values in ((11, {"joint": 8, "enable": 1}), (19, {"mode": 0}), (12, {"state": 0})):
        state, _ = call(emu, code, **values)
        assert not state & (STATE_ERROR | STATE_WARNING), (code, state)
    assert emu.controller.state == 2


def bits(state: int) -> tuple[bool, bool, bool]:
    """(error, warning, not ready) bits of a reply state byte."""
    return bool(state & STATE_ERROR), bool(state & STATE_WARNING), bool(state & STATE_NOT_READY)


def joints7(*q: float) -> tuple[float, ...]:
    return tuple(q) + (0.0,) * (7 - len(q))


def sdk_ready(arm: Any) -> None:
    """The SDK's start sequence on an ``XArmAPI``: each call returns 0."""
    assert arm.motion_enable(True) == 0
    assert arm.set_mode(0) == 0
    assert arm.set_state(0) == 0


def wait_for(pred: Callable[[], bool], timeout: float = 5.0) -> bool:
    """Poll ``pred`` every 10 ms until it holds or ``timeout`` (wall seconds) passes."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pred():
            return True
        time.sleep(0.01)
    return pred()


@dataclass
class FakeView:
    """A stand-in ControllerView for stepping a component on its own."""

    time: float = 0.0
    state: int = 0
    mode: int = 0
    error_code: int = 0
    warning_code: int = 0
    tcp_position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    is_moving: bool = False

    def raise_error(self, code: int) -> None:
        self.error_code = code


def rx(a: float) -> np.ndarray:
    """Rotation about x, written out independently of the project's rotations module."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def pose(x: float, y: float, z: float, roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0) -> np.ndarray:
    """4x4 pose (mm), R = Rz(yaw) Ry(pitch) Rx(roll) (manual 1.5), built independently of the package."""
    t = np.eye(4)
    t[:3, :3] = rz(yaw) @ ry(pitch) @ rx(roll)
    t[:3, 3] = (x, y, z)
    return t


def count_calls(monkeypatch: Any, owner: object, name: str) -> list[int]:
    """Replace ``owner.name`` (for the test) by a wrapper that counts its calls in the returned
    one-element list, calling the original."""
    original = getattr(owner, name)
    calls = [0]

    def counted(*args: Any, **kwargs: Any) -> Any:
        calls[0] += 1
        return original(*args, **kwargs)

    monkeypatch.setattr(owner, name, counted)
    return calls


def free_ports(n: int) -> list[int]:
    """``n`` distinct free loopback ports. With three or more, the port two below the third is free
    and not among them too: `serve` given these as command, normal, rich, develop (...) ports opens
    a 2.x box's real-time report there, beside the rich port."""
    while True:
        socks = [socket.socket() for _ in range(n)]
        try:
            for s in socks:
                s.bind(("127.0.0.1", 0))
            ports = [s.getsockname()[1] for s in socks]
            if n < 3:
                return ports
            with socket.socket() as s:
                try:
                    s.bind(("127.0.0.1", ports[2] - 2))
                except OSError:
                    continue
            return ports
        finally:
            for s in socks:
                s.close()


def serve_ports() -> tuple[list[int], int]:
    """Free ports for `serve` (command, normal, rich, develop) and the real-time report port a 2.x
    box opens beside them (two below the rich port), free too; wait on that one, the last the
    server binds: a child that cannot bind it exits after the others accepted connections."""
    ports = free_ports(4)
    return ports, ports[2] - 2


def port_args(cmd: int, normal: int, rich: int, develop: int) -> tuple[str, ...]:
    """`serve` options for a command port and the three report ports."""
    return ("--port", str(cmd), "--normal-port", str(normal), "--rich-port", str(rich),
            "--develop-port", str(develop))


@contextlib.contextmanager
def serve_subprocess(tmp_path: Path, *args: str) -> Iterator[subprocess.Popen[str]]:
    """`xarm-emu serve ARGS` in a child process (configuration in ``tmp_path``), terminated on exit."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "xarm_emu.cli", "serve", *args,
         "--config-dir", str(tmp_path), "--log-level", "WARNING"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env={**os.environ, "COLUMNS": "500"})
    try:
        yield proc
    finally:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        if proc.stdout is not None:
            proc.stdout.close()


def run_cli(*args: str) -> tuple[int, str]:
    """``xarm-emu ARGS`` through typer's CliRunner: (exit code, output)."""
    from typer.testing import CliRunner

    from xarm_emu import cli

    result = CliRunner().invoke(cli.app, list(args))
    return result.exit_code, result.output


def connect(port: int, timeout: float = 3.0) -> socket.socket:
    """A TCP_NODELAY connection to a loopback port (the command port's clients set it, manual 2.1.2)."""
    s = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def recv_exact(s: socket.socket, n: int) -> bytes:
    """Exactly ``n`` bytes from ``s``; ConnectionError if it closes first."""
    buf = b""
    while len(buf) < n:
        chunk = s.recv(n - len(buf))
        if not chunk:
            raise ConnectionError("closed")
        buf += chunk
    return buf


def recv_frame(s: socket.socket) -> bytes:
    """One command-port frame (manual 2.1.2: 6-byte header whose last u16 is the length after it)."""
    head = recv_exact(s, 6)
    (length,) = struct.unpack(">H", head[4:6])
    return head + recv_exact(s, length)


def accepts(port: int) -> bool:
    """Whether a loopback port accepts a connection now."""
    try:
        socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
    except OSError:
        return False
    return True


def report_frames_in(port: int, seconds: float) -> int:
    """Report frames (u32 BE length first, manual 2.1.6) received on ``port`` in ``seconds``."""
    got = 0
    with connect(port) as s:
        s.settimeout(0.5)
        end = time.monotonic() + seconds
        buf = b""
        while time.monotonic() < end:
            buf += s.recv(65536)
            while len(buf) >= 4:
                size = struct.unpack(">I", buf[:4])[0]
                if len(buf) < size:
                    break
                buf = buf[size:]
                got += 1
    return got


def read_frames(sock: socket.socket, seconds: float, poll: float = 0.05,
                stop: Callable[[], bool] = lambda: False) -> list[tuple[float, bytes]]:
    """Report frames (arrival time, bytes) read for ``seconds`` or until ``stop()``, each cut at the
    length it starts with (manual 2.1.6), waiting at most ``poll`` s per read."""
    out = []
    end = time.monotonic() + seconds
    buf = b""
    sock.settimeout(poll)
    while time.monotonic() < end and not stop():
        try:
            chunk = sock.recv(65536)
        except TimeoutError:
            continue
        assert chunk, "report connection closed"
        now = time.monotonic()
        buf += chunk
        while len(buf) >= 4:
            (size,) = struct.unpack(">I", buf[:4])
            if len(buf) < size:
                break
            out.append((now, buf[:size]))
            buf = buf[size:]
    return out


def step_both(fast: Emulator, exact: Emulator, script: dict[int, list[Callable[[Emulator], object]]],
              total: int, pattern: tuple[int, ...], observe: Callable[[Emulator], object]) -> int:
    """Step a jumping and an exact (``exact_steps=True``) emulator ``total`` periods in strides of
    ``pattern``, running ``script``'s actions (period count -> actions) on the same period in both
    and comparing ``observe`` of both after every stride; returns the instants compared."""
    for emu in (fast, exact):
        for action in script.get(0, []):
            action(emu)
    done = instants = 0
    marks = sorted(script)
    strides = itertools.cycle(pattern)
    while done < total:
        n = min(next(strides), total - done)
        upcoming = [m for m in marks if done < m < done + n]
        if upcoming:
            n = upcoming[0] - done  # actions land on the same period in both runs
        for emu in (fast, exact):
            emu.step(n)
        done += n
        for action in script.get(done, []):
            for emu in (fast, exact):
                action(emu)
        assert observe(fast) == observe(exact), f"differ after period {done} ({done * 0.004:.3f} s)"
        instants += 1
    return instants


def report_frames(emu: Emulator) -> tuple[bytes, ...]:
    """Every report frame the emulator's firmware sends (manual 2.1.6), encoded from one snapshot
    as the report ports do (firmware 2.x fields included)."""
    profile = emu.firmware
    snap = emu.snapshot()
    return tuple(enc(snap) for _, enc in sorted(encoders_for(profile).items()))


#: Where ``make sdk-examples`` unpacks the official SDK's source distribution (its ``example/``).
SDK_SOURCE = Path(__file__).resolve().parent.parent / ".sdk" / "xarm-python-sdk"
#: What a test that needs the SDK's example programs says when they are absent.
SDK_EXAMPLES_MISSING = ("the official SDK's example programs are absent: run `make sdk-examples` "
                        "(or set XARM_SDK_EXAMPLES to a checkout of xArm-Python-SDK)")


def sdk_examples() -> Path | None:
    """The ``example`` directory of the official SDK's source (the wheel does not ship it): under
    ``$XARM_SDK_EXAMPLES`` (a checkout of the SDK's repository, its unpacked source distribution or
    that ``example`` directory itself), else where ``make sdk-examples`` put it; None if neither."""
    env = os.environ.get("XARM_SDK_EXAMPLES")
    for base in ([Path(env)] if env else []) + [SDK_SOURCE]:
        for cand in (base / "example", base, base.parent.parent):
            if (cand / "wrapper" / "common").is_dir():
                return cand
    return None


def sdk_example(path: str) -> Path | None:
    """One program of the SDK's ``example`` directory (``wrapper/common/8001-force_tech.py``), or None."""
    root = sdk_examples()
    return root / path if root is not None and (root / path).is_file() else None
