"""The command-port trace (``xarm-emu serve --trace FILE``): what a program sent and what it got.

One JSON object per line, appended to ``FILE``:

- ``{"event": "start", "t": ..., "wall": ..., "model": "6", "firmware": "X.Y.Z", "gripper":
  "xarm", "vacuum": false, "linear_track": null, "ft_sensor": false, "ft_noise": false, "robot_sn":
  ..., "box_sn": ..., "saved": null, "calibration": null}`` when the emulator starts with the trace
  on: the box that answers the lines after it (its arm, the firmware it claims, its end tool, the
  linear track's length in mm, the F/T sensor and its noise, its serial numbers, the saved
  configuration it loaded from ``--config-dir``, the values of its file, and the constants of
  ``--calibration``, ``null`` for none), so ``xarm-emu replay``
  builds the same one; a file that several runs appended to holds one per run;
- ``{"event": "connect" | "close", "t": ..., "wall": ..., "peer": "127.0.0.1:40512"}`` for each
  command connection;
- ``{"t": ..., "wall": ..., "peer": ..., "tid": 5, "protocol": 2, "register": 21, "name":
  "MOVE_LINE", "params": "<hex>", "request": {...}, "state": 0, "reply": "<hex>", "values": {...}}``
  for each private-protocol request (manual 2.1.2): the raw parameter bytes and, where the register
  table can decode them, their values (NaN and infinities as the strings "NaN", "Infinity",
  "-Infinity", so every line is strict JSON); the reply's state byte, its raw parameters and their
  values. Registers are named and decoded with the table of the firmware the box claims (every
  register and layout it answers); ``request_error`` appears only where the box could not decode
  the request either, i.e. where it refused it. A reply that waits for a motion (register 204, load
  identification) is written when it goes out, with ``t_request`` the time it was asked. A
  command of the 3D view's pendant is such a line with ``peer`` "pendant" and ``tid`` 0;
- ``{"t": ..., "wall": ..., "peer": ..., "tid": 3, "protocol": 0, "unit": 1, "function": 3,
  "address": 32, "count": 2, "pdu": "<hex>", "reply": "<hex>", "exception": null, "read": [0, 0]}``
  for each standard Modbus request (protocol id 0): the function code, address, count, the values
  a write carries (``values``), the values a read got (``read``), and the exception code (``null``
  when none);
- ``{"event": "outside", "t": ..., "period": 4500, "wall": ..., "source": "schedule" | "admin",
  "request": {"cmd": "error", "code": "C31"}, "message": "injected C31 ..."}`` for each change made
  from outside the protocol as it is carried out: an entry of the fault schedule (``serve
  --faults``) as it fires, an admin request (``serve --admin``: faults, inputs, payload, scene,
  checkpoints; not the queries or ``step``) that was carried out (a refused one changes nothing and
  is not written). ``request`` is the admin request as given (without its token), ``period`` the
  control period it acted after (the controller's count since start), ``message`` what it answered.
  ``xarm-emu replay`` carries out the same request after the same period.

Request and ``outside`` lines are written under the arm's lock, in the order the arm saw the
requests and changes (a scheduled fault that fires while the report sender runs the control periods
comes before the command answered after it).

``t`` is controller time in seconds (the clock the motion runs on, scaled or stepped), ``wall`` the
Unix time. Lines are buffered and written at least every control-loop wake-up (20 ms) and on close,
so a trace read while the emulator runs may lag by that much; a killed emulator loses at most that.
The writes run on the server's disk worker; a write that fails stops the trace with one log line
(the cause: disk full, read-only, ...) and the emulator goes on.
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import os
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any

from ..protocol import registers as regs
from ..protocol.layouts import LayoutError
from ..protocol.modbus_pdu import describe
from .disk import DiskBusy, DiskWorker, describe_os_error

log = logging.getLogger("xarm_emu.server")

#: Lines collected between two flushes beyond which new ones are dropped (and counted).
MAX_BUFFERED_LINES = 100_000


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


def _json_tree(v: Any) -> Any:
    """An admin request (JSON, or a fault schedule's TOML) as strict JSON: tables kept, lists as
    lists, NaN and infinities as strings (:func:`_json_value`), anything else as its text."""
    if isinstance(v, dict):
        return {str(k): _json_tree(x) for k, x in v.items()}
    if isinstance(v, (tuple, list)):
        return [_json_tree(x) for x in v]
    if v is None or isinstance(v, (bool, int, float, str, bytes, bytearray)):
        return _json_value(v)
    return str(v)


class CommandTrace:
    """Appends trace lines to a file (module docstring).

    Lines are collected in the loop and handed to ``worker`` (the server's
    :class:`~xarm_emu.server.disk.DiskWorker`) at each :meth:`flush`, so the disk never holds the loop;
    without a worker they are written in place. A write that fails (disk full, read-only, I/O
    error) stops the trace with one log line naming the cause; the emulator goes on without it.
    """

    def __init__(self, path: Path | str, worker: DiskWorker | None = None, max_bytes: int = 0) -> None:
        self.path = Path(path)
        self.worker = worker
        #: At this size the file is renamed to ``<file>.1`` (replacing an older one) and a new one
        #: begun; 0: never.
        self.max_bytes = max_bytes
        self._file: IO[str] | None = open(self.path, "a", encoding="utf-8", buffering=1 << 16)  # noqa: SIM115
        self._lines: list[str] = []
        #: Lines come from the loop and, for a scheduled change that fires while the report sender
        #: runs the control periods, from its thread: collecting and taking them is atomic.
        self._lines_lock = threading.Lock()
        #: Why the trace stopped (``None`` while it runs), e.g. "disk full (ENOSPC)".
        self.stopped: str | None = None
        #: Lines lost to a full disk queue or after the trace stopped.
        self.dropped = 0

    def _write(self, record: dict[str, Any]) -> None:
        line = json.dumps(record, allow_nan=False) + "\n"  # strict JSON: _json_value
        with self._lines_lock:
            if self.stopped is not None or len(self._lines) >= MAX_BUFFERED_LINES:
                self.dropped += 1
                return
            self._lines.append(line)

    def event(self, t: float, peer: str, what: str) -> None:
        self._write({"event": what, "t": round(t, 6), "wall": time.time(), "peer": peer})

    def start(self, t: float, box: Mapping[str, Any]) -> None:
        """The emulator started at controller time ``t`` as ``box`` (module docstring)."""
        self._write({"event": "start", "t": round(t, 6), "wall": time.time(), **_json_tree(dict(box))})

    def outside(self, t: float, period: int, source: str, request: dict[str, Any], message: str) -> None:
        """A change made from outside the protocol (module docstring): the admin ``request`` as
        given (``source`` "admin" or "schedule"), carried out after control ``period`` at
        controller time ``t``, and the ``message`` it answered."""
        self._write({"event": "outside", "t": round(t, 6), "period": period, "wall": time.time(),
                     "source": source, "request": _json_tree(request), "message": message})

    def command(self, t: float, peer: str, tid: int, protocol: int, register: int, params: bytes,
                frame: bytes, table: Mapping[int, regs.Register] | None = None,
                asked: float | None = None) -> None:
        """One request and its reply ``frame`` (header, register, state, parameters), named and
        decoded with ``table``, the registers the box answers (default: the manual's). ``asked``:
        the controller time of a request whose reply waited for a motion (``t_request``)."""
        record: dict[str, Any] = {"t": round(t, 6), "wall": time.time(), "peer": peer, "tid": tid,
                                  "protocol": protocol, "register": register}
        if asked is not None:
            record["t_request"] = round(asked, 6)
        reg = (regs.REGISTERS if table is None else table).get(register)
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

    def modbus(self, t: float, peer: str, tid: int, unit: int, pdu: bytes, frame: bytes) -> None:
        """One standard Modbus request ``pdu`` and its reply ``frame`` (MBAP header and PDU)."""
        record: dict[str, Any] = {"t": round(t, 6), "wall": time.time(), "peer": peer, "tid": tid,
                                  "protocol": 0, "unit": unit}
        reply = bytes(frame[7:])
        record.update(describe(pdu, reply))
        record["pdu"] = pdu.hex()
        record["reply"] = reply.hex()
        self._write(record)

    def flush(self) -> None:
        """Hand the collected lines to the disk (the worker, else in place)."""
        with self._lines_lock:
            if not self._lines or self.stopped is not None:
                return
            lines, self._lines = self._lines, []
        text = "".join(lines)
        n = len(lines)
        if self.worker is None:
            self._append(text)
            return
        try:
            self.worker.submit(lambda: self._append(text))
        except DiskBusy:
            self.dropped += n

    def _append(self, text: str) -> None:
        """Write and flush ``text`` (on the worker); a failure stops the trace."""
        f = self._file
        if f is None or self.stopped is not None:
            return
        try:
            f.write(text)
            f.flush()
            if self.max_bytes > 0 and f.tell() >= self.max_bytes:
                f.close()
                self._file = None
                os.replace(self.path, self.path.with_name(self.path.name + ".1"))
                self._file = open(self.path, "a", encoding="utf-8", buffering=1 << 16)  # noqa: SIM115
        except OSError as exc:
            self._stop(exc)

    def _stop(self, exc: OSError) -> None:
        self.stopped = describe_os_error(exc)
        log.warning("trace %s stopped: %s; the emulator goes on without it", self.path, self.stopped)
        f, self._file = self._file, None
        if f is not None:
            with contextlib.suppress(OSError):
                f.close()

    def _close_file(self) -> None:
        f, self._file = self._file, None
        if f is not None:
            try:
                f.close()
            except OSError as exc:
                if self.stopped is None:
                    self.stopped = describe_os_error(exc)
                    log.warning("trace %s stopped: %s; the last lines are lost", self.path, self.stopped)

    def close(self) -> None:
        """Write what is collected and close the file (on the worker when there is one: the
        server's close then waits for it a bounded time)."""
        self.flush()
        if self.worker is None:
            self._close_file()
            return
        try:
            self.worker.submit(self._close_file)
        except DiskBusy:
            pass
