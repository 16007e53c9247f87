"""``status``: what a control box (real or emulated) says about itself over its command port and its
develop report (version, state, mode, errors, joints, pose, gripper, F/T sensor, linear track)."""

from __future__ import annotations

import json
import math
import time
from typing import Annotated, Any, cast

import typer
from rich.table import Table

from ..protocol import codes
from ..protocol.frame import COMMAND_PORT
from ..protocol.reports import DEVELOP_PORT
from .options import check_port, console, err_console

_STATES = {1: "in motion", 2: "sleep (ready)", 3: "suspend", 4: "stop", 5: "system reset"}
_MODES = {0: "position", 1: "servo", 2: "joint teaching", 3: "cartesian teaching"}


def status(
    host: Annotated[str, typer.Option(help="Control box address.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Command port.")] = COMMAND_PORT,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    report_port: Annotated[int, typer.Option(help="Develop report port, read for the mode.")] = DEVELOP_PORT,
    wait: Annotated[float, typer.Option(
        help="Readiness probe: retry for up to this many seconds until the control box answers on "
             "its command port (a protocol reply, not just an open port).")] = 0.0,
    linear_track: Annotated[bool, typer.Option(
        "--linear-track", help="Also read the linear track on the control box RS-485 (register 124, "
                               "host 11); off by default, as it talks to that bus.")] = False,
) -> None:
    """Print version, state, mode, error, warning, joints and pose of a control box (and its linear
    track with --linear-track).

    Exit status 1 when it cannot be reached (after ``--wait`` seconds of retries), so
    ``xarm-emu serve & xarm-emu status --wait 10`` is a CI readiness probe.
    """
    check_port("--port", port)
    check_port("--report-port", report_port)
    box = _read_box(host, port, wait, linear_track)
    version, joints, pose = box["version"], box["joints"], box["pose"]
    mode = _report_mode(host, report_port)
    axis = int(version.split(",")[0]) if version[:1].isdigit() else 7
    data = {"version": version, "state": box["state"], "mode": mode, "error": box["error"],
            "warning": box["warning"], "joints": list(joints[:axis]), "pose": list(pose),
            "gripper": box["gripper"],
            "joints_deg": [math.degrees(j) for j in joints[:axis]],
            "pose_mm_deg": [*pose[:3], *(math.degrees(p) for p in pose[3:])],
            "units": {"joints": "rad", "pose": "x, y, z mm; roll, pitch, yaw rad",
                      "joints_deg": "deg", "pose_mm_deg": "x, y, z mm; roll, pitch, yaw deg"}}
    if linear_track:  # null when nothing answers on the control box RS-485
        data["linear_track"] = box["track"]
        data["units"] = {**cast(dict[str, str], data["units"]), "linear_track": "position mm"}
    if box["ft"] is not None:
        data["ft_sensor"] = box["ft"]
    if as_json:
        print(json.dumps(data))
        return
    console.print(_status_table(box, mode, axis, linear_track))


def _read_box(host: str, port: int, wait: float, linear_track: bool) -> dict[str, Any]:
    """Everything ``status`` reads over the command port, retried for ``wait`` seconds; exit 1 when the
    box cannot be reached."""
    from ..client import Client, ClientError

    deadline = time.monotonic() + max(0.0, wait)
    while True:
        try:
            with Client(host, port, timeout=3.0) as c:
                version = c.get_version()
                state = c.get_state()
                error, warning = c.get_err_warn()
                joints = c.get_joints()
                pose = c.get_position()
                track = _track_status(c) if linear_track else None
                ft = _ft_status(c, version)
                gripper = _probe_gripper(c)
            break
        except (OSError, ClientError) as exc:
            if time.monotonic() < deadline:
                time.sleep(0.1)
                continue
            err_console.print(f"cannot reach the control box at {host}:{port}: {exc}")
            raise typer.Exit(1) from None
    return {"version": version, "state": state, "error": error, "warning": warning, "joints": joints,
            "pose": pose, "track": track, "ft": ft, "gripper": gripper}


def _report_mode(host: str, report_port: int) -> int | None:
    """The mode from one develop report, None when none comes."""
    from ..client import ClientError, subscribe

    try:  # no register reads the mode (manual 2.1.3): the report's state byte carries it
        return next(iter(subscribe("develop", host, report_port, timeout=2.0))).mode
    except (OSError, ClientError, StopIteration):
        return None


def _status_table(box: dict[str, Any], mode: int | None, axis: int, linear_track: bool) -> Table:
    """``status`` for a person: one row per item."""
    state, joints, pose, track, ft, gripper = (box[k] for k in ("state", "joints", "pose", "track", "ft",
                                                                 "gripper"))
    t = Table(show_header=False)
    t.add_row("version", box["version"])
    t.add_row("state", f"{state} ({_STATES.get(state, '?')})")
    t.add_row("mode", "unknown (no report)" if mode is None else f"{mode} ({_MODES.get(mode, '?')})")
    t.add_row("error", codes.describe_error(box["error"]))
    t.add_row("warning", codes.describe_warning(box["warning"]))
    t.add_row("joints (deg)", ", ".join(f"{math.degrees(j):.3f}" for j in joints[:axis]))
    t.add_row("pose (mm, deg)", ", ".join([f"{p:.3f}" for p in pose[:3]] +
                                          [f"{math.degrees(p):.3f}" for p in pose[3:]]))
    if linear_track:
        t.add_row("linear track", "no answer on the control box RS-485" if track is None else
                  f"{track['position']:.3f} mm, "
                  + ("moving" if track["moving"] else "at rest") + ", "
                  + ("enabled" if track["enabled"] else "disabled") + ", "
                  + ("on zero" if track["on_zero"] else "not homed") + f", error {track['error']}")
    if ft is not None:
        t.add_row("F/T sensor", "on: " + ", ".join(f"{x:.3f}" for x in ft["reading"]) + " (N, N m)"
                  if ft["enabled"] else "mounted, switched off")
    t.add_row("gripper", ", ".join(f"{k} {v}" for k, v in gripper.items()) if gripper else
              "none answers on the tool RS-485 at its present baud rate")
    return t


def _ft_status(c: Any, version: str) -> dict[str, Any] | None:
    """The F/T sensor as register 212 and the data register show it (a box without the sensor's
    registers has no register 212, and asking would raise its warning 13); None without a sensor."""
    from ..protocol.firmware import FirmwareProfile

    try:
        profile = FirmwareProfile.for_version(version.rsplit(",v", 1)[-1].lstrip("v"))
    except ValueError:
        return None
    if profile.ft_data_register != 200:  # no register 212 below the F/T sensor's registers
        return None
    config = c.call(212)
    if not config.values.get("type"):
        return None
    enabled = bool(config.values.get("started"))
    forces = list(c.call(profile.ft_data_register).values.get("forces", (0.0,) * 6)) if enabled else [0.0] * 6
    return {"enabled": enabled, "reading": [float(x) for x in forces],
            "units": "Fx, Fy, Fz N; Tx, Ty, Tz N m"}


def _track_status(c: Any) -> dict[str, Any] | None:
    """The linear track's registers 0x0A20-0x0A25 over register 124 (host 11, slave 1), or None
    when nothing answers on the control box RS-485."""
    from ..protocol import rtu

    reply = c.call(124, host=rtu.CONTROL_BOX_HOST, rtu=rtu.read_request(1, 0x0A20, 6))
    try:
        slave, func, words = rtu.parse_reply(bytes(reply["rtu"]))
    except (KeyError, ValueError):
        return None
    if (slave, func) != (1, rtu.READ_HOLDING) or len(words) != 6:
        return None
    pulses = (words[0] << 16 | words[1]) - (1 << 32 if words[0] & 0x8000 else 0)
    return {"position": pulses / 2000, "moving": bool(words[2] & 1), "error": words[3],
            "enabled": bool(words[4] & 1), "on_zero": bool(words[5] & 1)}


def _tool_read(c: Any, slave: int, address: int, count: int) -> tuple[int, ...] | None:
    """Read holding registers of a tool RS-485 slave through register 124 (manual 2.1.4); None when
    nothing answers or the reply is an exception."""
    from ..protocol import rtu

    try:
        r = c.call(124, host=rtu.TOOL_HOST, rtu=rtu.read_request(slave, address, count))
        slave_id, func, values = rtu.parse_reply(bytes(r["rtu"]))
    except (KeyError, ValueError):
        return None
    return tuple(values) if func == rtu.READ_HOLDING and slave_id == slave else None


def _probe_gripper(c: Any) -> dict[str, Any]:
    """Which gripper answers on the tool RS-485, read without changing its baud rate: a Robotiq
    (slave 9, status at 0x07D0), a BIO gripper (slave 8 with a serial number at 0x0B10) or the xArm
    gripper (slave 8); {} when none does."""
    robotiq = _tool_read(c, 9, 0x07D0, 3)
    if robotiq is not None:
        g_status, fault, g_pos = robotiq[0] >> 8, robotiq[1] >> 8, robotiq[2] >> 8
        return {"type": "robotiq", "gSTA": g_status >> 4 & 3, "gOBJ": g_status >> 6, "gPO": g_pos,
                "gFLT": fault & 0x0F}
    status = _tool_read(c, 8, 0x0000, 1)
    if status is None:
        return {}
    err = _tool_read(c, 8, 0x000F, 1) or (0,)
    pos = _tool_read(c, 8, 0x0702, 2) or (0, 0)
    position = int.from_bytes(bytes((pos[0] >> 8, pos[0] & 0xFF, pos[1] >> 8, pos[1] & 0xFF)), "big",
                              signed=True)
    kind = "bio" if _tool_read(c, 8, 0x0B10, 1) is not None else "xarm"
    return {"type": kind, "enabled": (status[0] >> 2 & 3) == 2, "motion": status[0] & 3,
            "position": position, "error": err[0]}

