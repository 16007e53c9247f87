"""``xarm-emu replay trace.jsonl``: a recorded program run again without the program.

Each request of a command trace (``serve --trace``, server/trace.py) is sent, with its recorded
transaction id, protocol id and parameter bytes, to a fresh emulator in stepped time that is first
run up to the controller time at which the recorded request was answered. Its reply (state byte and
parameters, manual 2.1.2) is compared with the recorded one: the same bytes, or the same decoded
values within ``tolerance`` where the register table decodes them. An unchanged emulator and
program give no difference; a change shows as the first reply that differs. Standard Modbus lines
(protocol id 0) are sent as their recorded PDU and their reply PDU is compared byte for byte.
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
from .server.trace import _plain

PERIOD_TOLERANCE = 1e-6


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
        return (f"line {self.line}, t = {self.t:.3f} s, register {self.register} ({self.name or '?'}): "
                f"{self.field} was {self.recorded!r}, now {self.replayed!r}")


@dataclass
class ReplayResult:
    """What a replay compared and what differed, in trace order."""

    requests: int = 0
    differences: list[Difference] = field(default_factory=list)

    @property
    def first(self) -> Difference | None:
        return self.differences[0] if self.differences else None


def read_requests(path: Path) -> list[tuple[int, dict[str, Any]]]:
    """The request lines of a trace as (line number, record), connection events left out."""
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


def replay(path: Path, model: int | str = 6, firmware: str | None = None, vacuum: bool = False,
           tolerance: float = PERIOD_TOLERANCE, stop_at_first: bool = False) -> ReplayResult:
    """Replay the trace at ``path`` into a fresh emulator of ``model`` (module docstring)."""
    from .controller.emulator import Emulator
    from .protocol.firmware import SERVE_VERSION
    from .server.core import EmulatorServer, ServerConfig

    requests = read_requests(path)
    result = ReplayResult()
    firmware = firmware or recorded_firmware(requests) or SERVE_VERSION
    with tempfile.TemporaryDirectory(prefix="xarm-emu-replay-") as cdir:
        emu = Emulator(model, config_dir=Path(cdir), vacuum=vacuum, firmware=firmware)
        server = EmulatorServer(emu, ServerConfig(stepped=True, admin=True, port=0))
        for n, rec in requests:
            t = float(rec.get("t_request", rec["t"]))  # a held reply: sent when it was asked
            if t > emu.time:
                server.advance(t - emu.time)
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
                    break
    return result
