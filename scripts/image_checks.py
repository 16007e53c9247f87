"""The image tests of ``scripts/image-test``: a built xarm-emu image run with ``--network host``, each
container's emulator on a loopback address of its own with the standard ports (command 502, reports
30001-30003, manual 2.1 and 2.2), so the unchanged official SDK connects as to a real arm.

Prints one line per check and closes with ``N passed, N failed``; exit status 1 if any failed.
"""

from __future__ import annotations

import json
import re
import socket
import subprocess
import sys
import time
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from datetime import datetime
from typing import Any

IMAGE = sys.argv[1] if len(sys.argv) > 1 else "xarm-emu:test"
VOLUME = "xarm-emu-image-test"
MAX_SIZE_MB = 250
MAX_HEALTHY_S = 2.0
MAX_STOP_S = 2.0
# The pod's and the compose file's command: the image's entrypoint with these options.
SERVE_ARGS = ["--speed", "5"]


def docker(*args: str, check: bool = True) -> str:
    out = subprocess.run(["docker", *args], capture_output=True, text=True, timeout=120)
    if check and out.returncode != 0:
        raise RuntimeError(f"docker {' '.join(args)}: {out.stderr.strip()}")
    return out.stdout.strip()


def inspect(name: str, fmt: str) -> Any:
    return json.loads(docker("inspect", "--format", "{{json " + fmt + "}}", name))


def stamp(text: str) -> datetime:
    """Docker's RFC 3339 time with nanoseconds, to microseconds."""
    return datetime.fromisoformat(re.sub(r"(\.\d{6})\d*", r"\1", text).replace("Z", "+00:00"))


def run(name: str, host: str, volume: str | None = None, args: tuple[str, ...] = (),
        host_by_argument: bool = False) -> tuple[float, float]:
    """Start a container serving on ``host`` (given as XARM_EMU_SERVE_HOST, or with
    ``host_by_argument`` as `--host` after the image name, which the health check reads too); returns the seconds ``docker run`` took (creating the
    container's file system, slow with the vfs storage driver) and from the container's start (its
    State.StartedAt) to the end of its first passing health check."""
    docker("rm", "-f", name, check=False)
    vol = ["-v", f"{volume}:/var/lib/xarm-emu"] if volume else []
    t0 = time.monotonic()
    where = ((), ("--host", host)) if host_by_argument else (("-e", f"XARM_EMU_SERVE_HOST={host}"), ())
    docker("run", "-d", "--name", name, "--network", "host", *where[0], *vol, IMAGE, *SERVE_ARGS, *where[1],
           *args)
    created = time.monotonic() - t0
    while time.monotonic() - t0 < 30:
        health = inspect(name, ".State.Health.Status")
        if health == "healthy":
            state = inspect(name, ".State")
            first = next(e for e in state["Health"]["Log"] if e["ExitCode"] == 0)
            return created, (stamp(first["End"]) - stamp(state["StartedAt"])).total_seconds()
        if not inspect(name, ".State.Running"):
            break
        time.sleep(0.05)
    raise RuntimeError(f"{name} did not become healthy: {docker('logs', name, check=False)}"
                       f"{inspect(name, '.State.Health')}")


@contextmanager
def sdk(host: str) -> Iterator[Any]:
    from xarm.wrapper import XArmAPI

    arm = XArmAPI(host, is_radian=False)
    try:
        yield arm
    finally:
        arm.disconnect()


def ready(arm: Any) -> None:
    assert arm.connected, "the SDK did not connect"
    assert arm.clean_error() == 0
    assert arm.motion_enable(enable=True) == 0
    assert arm.set_mode(0) == 0
    assert arm.set_state(0) == 0
    time.sleep(0.3)


RESULTS: list[tuple[str, bool]] = []


def check(name: str) -> Callable[[Callable[[], str | None]], None]:
    def wrap(fn: Callable[[], str | None]) -> None:
        try:
            note = fn()
        except Exception as exc:  # every failure is reported, the next check still runs
            RESULTS.append((name, False))
            print(f"FAIL {name}: {exc!r}")
            traceback.print_exc(limit=3, file=sys.stdout)
        else:
            RESULTS.append((name, True))
            print(f"ok   {name}" + (f": {note}" if note else ""))
    return wrap


def main() -> int:
    docker("volume", "rm", "-f", VOLUME, check=False)
    saved_offset = [0.0, 0.0, 42.0, 0.0, 0.0, 0.0]

    @check("runtime image under 250 MB")
    def size() -> str:
        mb = int(docker("image", "inspect", "--format", "{{.Size}}", IMAGE)) / 1e6
        assert mb < MAX_SIZE_MB, f"{mb:.0f} MB"
        return f"image size {mb:.0f} MB"

    @check("runs as a non-root user, admin channel off")
    def user() -> str:
        cfg = inspect(IMAGE, ".Config")
        assert cfg["User"] not in ("", "0", "root"), cfg["User"]
        assert cfg["Entrypoint"][-2:] == ["/opt/xarm-emu/bin/xarm-emu", "serve"][-2:]
        return f"user {cfg['User']}"

    @check("starts and becomes healthy under 2 s")
    def healthy() -> str:
        created, took = run("xarm-emu-a", "127.0.0.2", VOLUME)
        assert took < MAX_HEALTHY_S, f"{took:.2f} s"
        return f"start to healthy {took:.2f} s (docker run itself {created:.2f} s)"

    @check("no admin channel port open")
    def admin_closed() -> None:
        with socket.socket() as s:
            s.settimeout(1)
            assert s.connect_ex(("127.0.0.2", 10502)) != 0, "the admin port answers"

    @check("the unchanged SDK connects on 127.0.0.2:502, moves, saves its configuration")
    def moves() -> str:
        with sdk("127.0.0.2") as arm:
            ready(arm)
            assert arm.set_position(x=300, y=100, z=250, roll=180, pitch=0, yaw=0, speed=200, wait=True) == 0
            code, pos = arm.get_position()
            assert code == 0 and abs(pos[0] - 300) < 1 and abs(pos[1] - 100) < 1, pos
            assert arm.set_tcp_offset(saved_offset) == 0
            assert arm.save_conf() == 0
            return f"at {[round(p, 1) for p in pos[:3]]}"

    @check("docker stop exits cleanly within 2 s")
    def stops() -> str:
        t0 = time.monotonic()
        docker("stop", "xarm-emu-a")
        took = time.monotonic() - t0
        code = inspect("xarm-emu-a", ".State.ExitCode")
        assert code == 0, f"exit code {code}"
        assert took < MAX_STOP_S, f"{took:.2f} s"
        return f"stopped in {took:.2f} s, exit 0"

    @check("the saved configuration is there in a new container on the same volume")
    def persists() -> None:
        docker("rm", "-f", "xarm-emu-a", check=False)
        run("xarm-emu-b", "127.0.0.2", VOLUME)
        with sdk("127.0.0.2") as arm:
            time.sleep(0.5)
            offset = [round(v, 3) for v in arm.tcp_offset]
            assert offset == saved_offset, offset
        docker("rm", "-f", "xarm-emu-b", check=False)

    @check("two containers serve two arms side by side (an xArm6, and an xArm7 by --model 7 --host)")
    def two() -> str:
        run("xarm-emu-c", "127.0.0.3")
        _, took = run("xarm-emu-d", "127.0.0.4", args=("--model", "7"), host_by_argument=True)
        assert took < MAX_HEALTHY_S, f"healthy by --host after {took:.2f} s"
        with sdk("127.0.0.3") as c, sdk("127.0.0.4") as d:
            ready(c)
            ready(d)
            assert (c.axis, d.axis) == (6, 7), (c.axis, d.axis)
            assert c.set_servo_angle(angle=[30, 0, 0, 0, 0, 0], speed=60, wait=True) == 0
            time.sleep(0.3)
            jc, jd = c.get_servo_angle()[1], d.get_servo_angle()[1]
            assert abs(jc[0] - 30) < 0.5 and abs(jd[0]) < 0.5, (jc, jd)
            time.sleep(2)  # idle with a client on each report port: the cost of an arm at rest
            stats = docker("stats", "--no-stream", "--format", "{{.Name}} {{.CPUPerc}} {{.MemUsage}}",
                           "xarm-emu-c", "xarm-emu-d")
        return "per arm (idle, SDK connected): " + "; ".join(stats.splitlines())

    for name in ("xarm-emu-a", "xarm-emu-b", "xarm-emu-c", "xarm-emu-d"):
        docker("rm", "-f", name, check=False)
    docker("volume", "rm", "-f", VOLUME, check=False)
    passed = sum(ok for _, ok in RESULTS)
    print(f"{passed} passed, {len(RESULTS) - passed} failed")
    return 0 if passed == len(RESULTS) else 1


if __name__ == "__main__":
    sys.exit(main())
