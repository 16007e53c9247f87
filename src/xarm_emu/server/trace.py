"""The command-port trace (``xarm-emu serve --trace FILE``): what a program sent and what it got.

One JSON object per line, appended to ``FILE``:

- ``{"event": "connect" | "close", "t": ..., "wall": ..., "peer": "127.0.0.1:40512"}`` for each
  command connection;
- ``{"t": ..., "wall": ..., "peer": ..., "tid": 5, "protocol": 2, "register": 21, "name":
  "MOVE_LINE", "params": "<hex>", "request": {...}, "state": 0, "reply": "<hex>", "values": {...}}``
  for each private-protocol request (manual 2.1.2): the raw parameter bytes and, where the register
  table can decode them, their values (NaN and infinities as the strings "NaN", "Infinity",
  "-Infinity", so every line is strict JSON); the reply's state byte, its raw parameters and their
  values.

``t`` is controller time in seconds (the clock the motion runs on, scaled or stepped), ``wall`` the
Unix time. Lines are buffered and written at least every control-loop wake-up (20 ms) and on close,
so a trace read while the emulator runs may lag by that much; a killed emulator loses at most that.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import IO, Any

from ..protocol import registers as regs
from ..protocol.layouts import LayoutError


def _json_value(v: Any) -> Any:
    """One decoded value as strict JSON: bytes as hex, tuples as lists, NaN and infinities as the
    strings "NaN", "Infinity", "-Infinity" (the raw bytes stay in ``params``)."""
    if isinstance(v, (bytes, bytearray)):
        return bytes(v).hex()
    if isinstance(v, (tuple, list)):
        return [_json_value(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return "NaN" if math.isnan(v) else ("Infinity" if v > 0 else "-Infinity")
    return v


def _plain(values: dict[str, Any]) -> dict[str, Any]:
    """Decoded layout values as strict JSON."""
    return {k: _json_value(v) for k, v in values.items()}


class CommandTrace:
    """Appends trace lines to a file (module docstring)."""

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        self._file: IO[str] | None = open(self.path, "a", encoding="utf-8", buffering=1 << 16)  # noqa: SIM115

    def _write(self, record: dict[str, Any]) -> None:
        if self._file is not None:
            self._file.write(json.dumps(record, allow_nan=False) + "\n")  # strict JSON: _json_value

    def event(self, t: float, peer: str, what: str) -> None:
        self._write({"event": what, "t": round(t, 6), "wall": time.time(), "peer": peer})

    def command(self, t: float, peer: str, tid: int, protocol: int, register: int, params: bytes,
                frame: bytes) -> None:
        """One request and its reply ``frame`` (header, register, state, parameters)."""
        record: dict[str, Any] = {"t": round(t, 6), "wall": time.time(), "peer": peer, "tid": tid,
                                  "protocol": protocol, "register": register}
        reg = regs.get(register)
        state, reply = (frame[7], frame[8:]) if len(frame) >= 8 else (None, b"")
        record["name"] = reg.name if reg is not None else None
        record["params"] = params.hex()
        if reg is not None:
            try:
                record["request"] = _plain(reg.request.decode(params))
            except LayoutError as exc:
                record["request_error"] = str(exc)
        record["state"] = state
        record["reply"] = bytes(reply).hex()
        if reg is not None and reply:
            try:
                record["values"] = _plain(reg.reply.decode(bytes(reply)))
            except LayoutError:
                pass
        self._write(record)

    def flush(self) -> None:
        if self._file is not None:
            self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
