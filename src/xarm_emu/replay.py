"""``xarm-emu replay trace.jsonl``: a recorded program run again without the program.

Each request of a command trace (``serve --trace``, server/trace.py) is sent, with its recorded
transaction id, protocol id and parameter bytes, to a fresh emulator in stepped time that is first
run up to the controller time at which the recorded request was answered. Its reply (state byte and
parameters, manual 2.1.2) is compared with the recorded one: the same bytes, or the same decoded
values within ``tolerance`` where the register table decodes them. An unchanged emulator and
program give no difference; a change shows as the first reply that differs. Standard Modbus lines
(protocol id 0) are sent as their recorded PDU and their reply PDU is compared byte for byte.

The trace's ``start`` line says which box answered (arm, firmware, end tool, linear track, F/T
sensor, serial numbers, the saved configuration it loaded, the calibration); the replay builds the
same one unless told otherwise, and a fresh one at each ``start`` line of a file that several runs
appended to. A trace without it replays into the box the options give (an xArm 6 by default, at
the firmware its register 1 reply claimed).

What was changed from outside the protocol (the trace's ``outside`` lines: fault schedule entries as
they fired, admin injections and inputs) is carried out again, in trace order, after the control
period it acted after in the recorded run (:func:`~xarm_emu.server.placement.run_to`, as
``compare`` places what it re-runs), as the same admin request. One the
replay's emulator refuses (a scene object the replay has no scene for) is a difference. A trace
written before these lines existed replays as before.
"""

from __future__ import annotations

import json
import math
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .protocol import registers as regs
from .protocol.layouts import LayoutError
from .server.placement import run_to
from .server.trace import _plain

PERIOD_TOLERANCE = 1e-6
#: A trace line's ``event`` for a change made from outside the protocol (server/trace.py), and the
#: :attr:`Difference.field` of one the replay could not carry out.
OUTSIDE = "outside"
#: A trace line's ``event`` when the emulator started: the box it was (server/trace.py).
START = "start"


class ReplayError(ValueError):
    """The trace cannot be replayed; the message says which line and why."""


@dataclass(frozen=True)
class Difference:
    """One reply of the new run that differs from the recorded one."""

    line: int
    t: float
    register: int
    name: str | None
    field: str  # "state", "reply" or a decoded value's name
    recorded: Any
    replayed: Any

    def describe(self) -> str:
        if self.field == OUTSIDE:
            return (f"line {self.line}, t = {self.t:.3f} s, {self.name}: was {self.recorded!r}, "
                    f"now refused: {self.replayed}")
        return (f"line {self.line}, t = {self.t:.3f} s, register {self.register} ({self.name or '?'}): "
                f"{self.field} was {self.recorded!r}, now {self.replayed!r}")


@dataclass
class ReplayResult:
    """What a replay compared and what differed, in trace order."""

    requests: int = 0
    #: Changes from outside the protocol carried out again (the trace's ``outside`` lines).
    outside: int = 0
    differences: list[Difference] = field(default_factory=list)

    @property
    def first(self) -> Difference | None:
        return self.differences[0] if self.differences else None


def read_requests(path: Path) -> list[tuple[int, dict[str, Any]]]:
    """The request lines of a trace as (line number, record), every event left out."""
    return [(n, rec) for n, rec in read_trace(path) if "event" not in rec]


def read_trace(path: Path) -> list[tuple[int, dict[str, Any]]]:
    """The request lines and the ``outside`` events of a trace as (line number, record), in trace
    order; connection events (and event kinds this version does not know) left out."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ReplayError(f"cannot read {path}: {exc.strerror or exc}") from None
    out = []
    for n, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
        except ValueError:
            raise ReplayError(f"{path} line {n} is not JSON (a trace of serve --trace)") from None
        if not isinstance(rec, dict):
            raise ReplayError(f"{path} line {n} is not a trace line")
        if "event" in rec:
            if rec["event"] == OUTSIDE:
                out.append((n, _outside_line(path, n, rec)))
            elif rec["event"] == START:
                out.append((n, rec))
            continue
        try:
            float(rec["t"]), int(rec["tid"]), bytes.fromhex(rec["reply"])
            if int(rec["protocol"]) == 0:
                int(rec["unit"]), bytes.fromhex(rec["pdu"])
            else:
                int(rec["register"]), bytes.fromhex(rec["params"])
        except (KeyError, TypeError, ValueError):
            raise ReplayError(f"{path} line {n}: a request line needs t, tid, protocol, register, "
                              "params and reply (unit and pdu for protocol 0)") from None
        out.append((n, rec))
    return out


def _outside_line(path: Path, n: int, rec: dict[str, Any]) -> dict[str, Any]:
    """An ``outside`` line checked: its time, its period (when given) and its admin request."""
    try:
        float(rec["t"])
        if rec.get("period") is not None:
            int(rec["period"])
        ok = isinstance(rec["request"], dict) and isinstance(rec["request"].get("cmd"), str)
    except (KeyError, TypeError, ValueError):
        ok = False
    if not ok:
        raise ReplayError(f"{path} line {n}: an outside line needs t, period and request (an admin "
                          "request with its cmd)")
    return rec


def _outside(server: Any, n: int, rec: dict[str, Any]) -> Difference | None:
    """Carry out an ``outside`` line's admin request again; a refusal is a difference."""
    from .server.admin import AdminError, prepare

    request = dict(rec["request"])
    who = "fault schedule" if rec.get("source") == "schedule" else "admin"
    try:
        prepare(server, request, str(rec.get("source") or "admin"))()
    except AdminError as exc:
        return Difference(n, float(rec["t"]), 0, f"{who} {request.get('cmd')}", OUTSIDE,
                          rec.get("message"), str(exc))
    return None


def _close(a: Any, b: Any, tolerance: float) -> bool:
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y, tolerance) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) or isinstance(b, float):
        if isinstance(a, (int, float)) and isinstance(b, (int, float)):
            return math.isclose(a, b, rel_tol=tolerance, abs_tol=tolerance)
    return bool(a == b)


def _compare_modbus(n: int, rec: dict[str, Any], reply: bytes) -> Difference | None:
    """A standard Modbus reply PDU against the recorded one: the same bytes."""
    if bytes.fromhex(rec["reply"]) == reply:
        return None
    name = f"Modbus function {rec.get('function')} at {rec.get('address')}"
    address = int(rec.get("address") or 0)
    return Difference(n, float(rec["t"]), address, name, "reply", rec["reply"], reply.hex())


def _compare(n: int, rec: dict[str, Any], state: int, reply: bytes, tolerance: float,
             table: Mapping[int, regs.Register]) -> Difference | None:
    register = int(rec["register"])
    name = rec.get("name")
    t = float(rec["t"])
    if rec.get("state") != state:
        return Difference(n, t, register, name, "state", rec.get("state"), state)
    if bytes.fromhex(rec["reply"]) == reply:
        return None
    reg = table.get(register)
    recorded = rec.get("values")
    if reg is not None and recorded is not None and reply:
        try:
            replayed = _plain(reg.reply.decode(reply))
        except LayoutError:
            replayed = None
        if replayed is not None:
            for key in sorted(set(recorded) | set(replayed)):
                if not _close(recorded.get(key), replayed.get(key), tolerance):
                    return Difference(n, t, register, name, key, recorded.get(key), replayed.get(key))
            return None
    return Difference(n, t, register, name, "reply", rec["reply"], reply.hex())


def recorded_firmware(requests: list[tuple[int, dict[str, Any]]]) -> str | None:
    """The firmware version the recorded box claimed in its register 1 reply, if the trace has one."""
    for _, rec in requests:
        version = (rec.get("values") or {}).get("version") if rec.get("register") == 1 else None
        if isinstance(version, str) and ",v" in version:
            return version.rsplit(",v", 1)[1].strip("\0 ")
    return None


Lines = list[tuple[int, dict[str, Any]]]


def runs(lines: Lines) -> list[tuple[dict[str, Any], Lines]]:
    """The trace's lines by run: each ``start`` line (``{}`` before the first) with the lines after it."""
    out: list[tuple[dict[str, Any], Lines]] = [({}, [])]
    for n, rec in lines:
        if rec.get("event") == START:
            out.append((rec, []))
        else:
            out[-1][1].append((n, rec))
    return [r for r in out if r[1] or r[0]]


def _emulator(start: dict[str, Any], lines: list[tuple[int, dict[str, Any]]], config_dir: Path,
              model: int | str | None, firmware: str | None, vacuum: bool | None) -> Any:
    """The box of a run: as the options say, else as its ``start`` line says, else an xArm 6 at the
    firmware its register 1 reply claimed (else serve's)."""
    from .controller.core.config import ConfigStore
    from .controller.emulator import Emulator
    from .model.calibration import from_dict
    from .model.robots import get_model, with_calibration
    from .protocol.firmware import SERVE_VERSION

    def given(key: str, default: Any) -> Any:
        v = start.get(key)
        return default if v is None else v

    requests = [x for x in lines if "event" not in x[1]]
    robot: Any = model if model is not None else str(given("model", 6))
    own = start if model is None else {}  # another arm than the trace's: its own numbers, no saved file
    robot_sn, box_sn, saved = own.get("robot_sn"), own.get("box_sn"), own.get("saved")
    try:
        if isinstance(own.get("calibration"), dict):  # serve --calibration: the same constants
            robot = with_calibration(get_model(robot), from_dict(dict(own["calibration"])))
        if isinstance(saved, dict) and robot_sn:  # the configuration it loaded, loaded again
            store = ConfigStore(config_dir, str(robot_sn))
            store.write_encoded(store.encode(saved))
        emu = Emulator(robot, config_dir=config_dir, robot_sn=robot_sn, box_sn=box_sn,
                       vacuum=vacuum if vacuum is not None else bool(given("vacuum", False)),
                       firmware=(firmware or given("firmware", None) or recorded_firmware(requests)
                                 or SERVE_VERSION),
                       gripper=str(given("gripper", "xarm")), linear_track=given("linear_track", None),
                       ft_sensor=bool(given("ft_sensor", False)), ft_noise=bool(given("ft_noise", True)))
    except (ValueError, TypeError, OSError, KeyError) as exc:
        raise ReplayError(f"the trace's box cannot be built: {exc}") from None
    return emu


def replay(path: Path, model: int | str | None = None, firmware: str | None = None,
           vacuum: bool | None = None, tolerance: float = PERIOD_TOLERANCE,
           stop_at_first: bool = False) -> ReplayResult:
    """Replay the trace at ``path`` (module docstring); ``model``, ``firmware`` and ``vacuum``, when
    given, replace what the trace says of the box."""
    result = ReplayResult()
    for start, lines in runs(read_trace(path)):
        if _replay_run(start, lines, result, model, firmware, vacuum, tolerance, stop_at_first):
            break
    return result


def _replay_run(start: dict[str, Any], lines: list[tuple[int, dict[str, Any]]], result: ReplayResult,
                model: int | str | None, firmware: str | None, vacuum: bool | None, tolerance: float,
                stop_at_first: bool) -> bool:
    """One run of the trace into a fresh box; True when it stopped at a difference."""
    from .server.core import EmulatorServer, ServerConfig

    with tempfile.TemporaryDirectory(prefix="xarm-emu-replay-") as cdir:
        emu = _emulator(start, lines, Path(cdir), model, firmware, vacuum)
        server = EmulatorServer(emu, ServerConfig(stepped=True, admin=True, port=0))
        for n, rec in lines:
            if rec.get("event") == OUTSIDE:
                run_to(server, float(rec["t"]), rec.get("period"))
                result.outside += 1
                diff = _outside(server, n, rec)
                if diff is not None:
                    result.differences.append(diff)
                    if stop_at_first:
                        return True
                continue
            run_to(server, float(rec.get("t_request", rec["t"])))  # a held reply: sent when it was asked
            result.requests += 1
            if int(rec["protocol"]) == 0:
                frame = server.answer_modbus(int(rec["tid"]), int(rec["unit"]), bytes.fromhex(rec["pdu"]))
                diff = _compare_modbus(n, rec, bytes(frame[7:]))
            else:
                frame = server.answer(int(rec["tid"]), int(rec["protocol"]), int(rec["register"]),
                                      bytes.fromhex(rec["params"]))
                held = server.finish_held(int(rec["tid"]), int(rec["protocol"]), int(rec["register"]))
                frame = held if held is not None else frame
                diff = _compare(n, rec, frame[7] if len(frame) >= 8 else -1, bytes(frame[8:]), tolerance,
                                emu.controller.registers)
            if diff is not None:
                result.differences.append(diff)
                if stop_at_first:
                    return True
    return False
