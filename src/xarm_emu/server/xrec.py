"""The ``.xrec`` recording of a session through ``xarm-emu proxy``: what a program and a control box said.

Format 1. A file is one gzip stream (flushed to a byte boundary every second as the session goes,
so a killed proxy leaves every record flushed so far readable) of records, each its length (u32
big-endian) and a MessagePack map tagged by ``k``:

- ``header``: ``format`` (1), ``created`` (Unix time), ``target`` (the box's address), ``ports``
  (standard port -> the box's port the proxy forwarded to).
- ``open`` / ``close``: a connection ``conn`` (numbered from 1) on standard ``port`` (502, 30000-30003)
  from ``peer``.
- ``req``: a command-port frame the program sent (manual 2.1.2): the whole ``frame`` as sent, its
  ``tid``, ``protocol``, ``register`` (for protocol 0, the unit id), the register's ``name`` and the
  decoded ``values`` of its parameters where the register table of the box's firmware decodes them.
- ``rep``: a command-port frame the box sent: a reply (``state`` byte) or, with ``register`` 255, a
  feedback frame of firmware 2.x; ``frame``, ``tid``, ``protocol``, ``register``, ``name``,
  ``values`` as for ``req``.
- ``rpt``: one report frame (manual 2.1.6) of report ``port``, as the box sent it.
- ``raw``: bytes no frame could be cut from (``dir`` 0 program -> box, 1 box -> program).
- ``fw``: the firmware ``version`` the box reported in its register 1 reply; frames after it are
  decoded with that firmware's table.
- ``stats``: written on close: ``latency`` (seconds the proxy held a command-port chunk, as
  percentiles 50, 90, 99 and the maximum) and ``bytes`` forwarded per direction.

Every record has ``t``: seconds since the recording began, on the proxy's monotonic clock, taken when
the bytes were read. Readers skip record kinds they do not know; a new field never changes the
meaning of an old one, and a change that would bumps ``format``.
"""

from __future__ import annotations

import queue
import threading
import time
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgspec

from ..protocol import registers as regs
from ..protocol.firmware import DEFAULT_PROFILE, FirmwareProfile, VersionError, profile_for
from ..protocol.frame import COMMAND_PORT as _COMMAND_PORT
from ..protocol.frame import PRIVATE_PROTOCOLS, FrameDecoder, FrameError
from ..protocol.layouts import LayoutError
from .trace import _plain

FORMAT = 1
#: Seconds between two full flushes of the compressed stream to the file (what a killed proxy can lose).
FLUSH_EVERY = 1.0
#: zlib's window bits for a gzip container (16 + 15), and for reading either gzip or zlib (32 + 15).
_GZIP_WBITS, _READ_WBITS = 31, 47
COMMAND_PORT = _COMMAND_PORT
TO_BOX, TO_PROGRAM = 0, 1


class Header(msgspec.Struct, tag="header", tag_field="k"):
    format: int
    created: float
    target: str
    ports: dict[int, int]
    t: float = 0.0


class Open(msgspec.Struct, tag="open", tag_field="k"):
    t: float
    conn: int
    port: int
    peer: str = ""


class Close(msgspec.Struct, tag="close", tag_field="k"):
    t: float
    conn: int
    port: int


class _Command(msgspec.Struct):
    """What a request and a reply of the command port both record (manual 2.1.2 frame head)."""

    t: float
    conn: int
    frame: bytes
    tid: int
    protocol: int
    register: int


class Req(_Command, tag="req", tag_field="k"):
    name: str | None = None
    values: dict[str, Any] | None = None

    @property
    def params(self) -> bytes:
        return self.frame[7:]


class Rep(_Command, tag="rep", tag_field="k"):
    state: int
    name: str | None = None
    values: dict[str, Any] | None = None

    @property
    def params(self) -> bytes:
        return self.frame[8:]


class Rpt(msgspec.Struct, tag="rpt", tag_field="k"):
    t: float
    conn: int
    port: int
    frame: bytes


class Raw(msgspec.Struct, tag="raw", tag_field="k"):
    t: float
    conn: int
    port: int
    dir: int
    data: bytes


class Fw(msgspec.Struct, tag="fw", tag_field="k"):
    t: float
    version: str


class Stats(msgspec.Struct, tag="stats", tag_field="k"):
    t: float
    latency: dict[str, float]
    bytes: dict[str, int]


Record = Header | Open | Close | Req | Rep | Rpt | Raw | Fw | Stats


class RecordingError(ValueError):
    """A recording that cannot be read or written; the message says which and why."""


def firmware_of(version: str) -> FirmwareProfile | None:
    """The profile of a register 1 version string (``"6,6,XI1304,AC1303,vX.Y.Z"``), if supported."""
    if ",v" not in version:
        return None
    try:
        return profile_for(version.rsplit(",v", 1)[1].strip("\0 "))
    except (VersionError, ValueError):
        return None


class _Stream:
    """Frames cut from one direction of one connection."""

    def __init__(self, port: int, direction: int) -> None:
        self.port, self.dir = port, direction
        self.frames: FrameDecoder | None = FrameDecoder(replies=direction == TO_PROGRAM)
        self.buf = bytearray()


class RecordWriter:
    """Writes records on a thread of its own: the proxy only queues the bytes it forwarded
    (:meth:`data`), so cutting frames, decoding and compressing never delay a byte on the wire."""

    def __init__(self, path: Path | str, target: str, ports: dict[int, int], level: int = 6) -> None:
        self.path = Path(path)
        try:
            self._file = open(self.path, "wb")  # noqa: SIM115  (closed by close())
        except OSError as exc:
            raise RecordingError(f"cannot write {self.path}: {exc.strerror or exc}") from None
        self._zw = zlib.compressobj(level, zlib.DEFLATED, _GZIP_WBITS)
        self._enc = msgspec.msgpack.Encoder()
        self._q: queue.SimpleQueue[tuple[Any, ...] | None] = queue.SimpleQueue()
        self._t0 = time.perf_counter()
        self._streams: dict[tuple[int, int], _Stream] = {}
        self._profile = DEFAULT_PROFILE
        self._table = regs.registers_for(self._profile)
        self.records = 0
        self.error: str | None = None
        self._put(Header(FORMAT, time.time(), target, dict(ports)))
        self._thread = threading.Thread(target=self._run, name="xrec-writer", daemon=True)
        self._thread.start()

    def now(self) -> float:
        """Seconds since the recording began."""
        return time.perf_counter() - self._t0

    # --- called on the proxy's event loop: queue only ---
    def opened(self, conn: int, port: int, peer: str) -> None:
        self._q.put(("open", self.now(), conn, port, peer))

    def closed(self, conn: int, port: int) -> None:
        self._q.put(("close", self.now(), conn, port))

    def data(self, t: float, conn: int, port: int, direction: int, data: bytes) -> None:
        self._q.put(("data", t, conn, port, direction, data))

    def stats(self, latency: dict[str, float], counts: dict[str, int]) -> None:
        self._q.put(("stats", self.now(), latency, counts))

    def close(self) -> None:
        """Write what is queued and close the file."""
        self._q.put(None)
        self._thread.join()

    # --- the writer thread ---
    def _put(self, record: Record) -> None:
        payload = self._enc.encode(record)
        self._file.write(self._zw.compress(len(payload).to_bytes(4, "big") + payload))
        self.records += 1

    def _run(self) -> None:
        last = time.monotonic()
        try:
            while True:
                try:
                    item = self._q.get(timeout=FLUSH_EVERY)
                except queue.Empty:
                    item = ()
                if item is None:
                    break
                if item:
                    self._handle(item)
                if time.monotonic() - last >= FLUSH_EVERY:  # every record so far decodable on disk
                    self._file.write(self._zw.flush(zlib.Z_FULL_FLUSH))
                    self._file.flush()
                    last = time.monotonic()
            self._file.write(self._zw.flush(zlib.Z_FINISH))
        except OSError as exc:
            self.error = f"cannot write {self.path}: {exc.strerror or exc}"
        finally:
            try:
                self._file.close()
            except OSError:
                pass

    def _handle(self, item: tuple[Any, ...]) -> None:
        kind, t = item[0], item[1]
        if kind == "open":
            self._put(Open(t, item[2], item[3], item[4]))
        elif kind == "close":
            self._put(Close(t, item[2], item[3]))
            for d in (TO_BOX, TO_PROGRAM):
                self._streams.pop((item[2], d), None)
        elif kind == "stats":
            self._put(Stats(t, item[2], item[3]))
        else:
            _, t, conn, port, direction, data = item
            st = self._streams.get((conn, direction))
            if st is None:
                st = self._streams[(conn, direction)] = _Stream(port, direction)
            if port == COMMAND_PORT:
                self._command(t, conn, st, data)
            else:
                self._report(t, conn, st, data)

    def _command(self, t: float, conn: int, st: _Stream, data: bytes) -> None:
        if st.frames is None:
            self._put(Raw(t, conn, st.port, st.dir, data))
            return
        try:
            frames = st.frames.feed(data)
        except FrameError:
            st.frames = None
            self._put(Raw(t, conn, st.port, st.dir, data))
            return
        for f in frames:
            reg = self._table.get(f.register) if f.protocol in PRIVATE_PROTOCOLS else None
            name = reg.name if reg is not None else ("FEEDBACK" if f.register == 0xFF and st.dir else None)
            if st.dir == TO_BOX:
                frame = f.encode()
                values = self._decode(reg, "request", f.params)
                self._put(Req(t, conn, frame, f.tid, f.protocol, f.register, name, values))
            else:
                frame = f.encode()
                values = self._decode(reg, "reply", f.params)
                self._put(Rep(t, conn, frame, f.tid, f.protocol, f.register, f.state,  # type: ignore[union-attr]
                              name, values))
                if f.register == 1 and values and isinstance(values.get("version"), str):
                    profile = firmware_of(values["version"])
                    if profile is not None and profile != self._profile:
                        self._profile, self._table = profile, regs.registers_for(profile)
                        self._put(Fw(t, values["version"].strip("\0 ")))

    @staticmethod
    def _decode(reg: regs.Register | None, side: str, params: bytes) -> dict[str, Any] | None:
        if reg is None or not params:
            return None
        try:
            return _plain(getattr(reg, side).decode(params))
        except (LayoutError, ValueError):
            return None

    def _report(self, t: float, conn: int, st: _Stream, data: bytes) -> None:
        """Report frames start with their size, u32 big-endian (manual 2.1.6)."""
        if st.dir == TO_BOX:
            self._put(Raw(t, conn, st.port, st.dir, data))
            return
        buf = st.buf
        buf += data
        while len(buf) >= 4:
            size = int.from_bytes(buf[:4], "big")
            if size < 4 or size > 1 << 16:
                self._put(Raw(t, conn, st.port, st.dir, bytes(buf)))
                buf.clear()
                return
            if len(buf) < size:
                return
            self._put(Rpt(t, conn, st.port, bytes(buf[:size])))
            del buf[:size]


_DECODER = msgspec.msgpack.Decoder(Record)


def read(path: Path | str) -> Iterator[Record]:
    """The records of a recording in order; ``RecordingError`` for a file that is not one. A stream
    cut short (a killed proxy) ends at the last whole record."""
    path = Path(path)
    try:
        f = open(path, "rb")  # noqa: SIM115
    except OSError as exc:
        raise RecordingError(f"cannot read {path}: {exc.strerror or exc}") from None
    with f:
        inflate = zlib.decompressobj(_READ_WBITS)
        unpacker = _Unpacker()
        first = True
        while not inflate.eof:
            data = f.read(1 << 16)  # a few MB of records decompressed at a time, not tens
            if not data:
                return  # a stream cut short ends at its last whole record
            try:
                chunk = inflate.decompress(data)
            except zlib.error as exc:
                if first:
                    raise RecordingError(f"{path} is not an xarm-emu recording (.xrec): {exc}") from None
                return
            for rec in unpacker.feed(chunk):
                if first:
                    if not isinstance(rec, Header):
                        raise RecordingError(f"{path} does not begin with a recording header")
                    if rec.format != FORMAT:
                        raise RecordingError(f"{path} is recording format {rec.format}; this version reads "
                                             f"{FORMAT}")
                    first = False
                yield rec


class _Unpacker:
    """Cuts whole records from the decompressed stream: each is its length (u32 big-endian) and
    its MessagePack bytes."""

    def __init__(self) -> None:
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[Record]:
        buf = self._buf
        buf += data
        out: list[Record] = []
        pos = 0
        while len(buf) - pos >= 4:
            end = pos + 4 + int.from_bytes(buf[pos:pos + 4], "big")
            if end > len(buf):
                break
            try:
                out.append(_DECODER.decode(buf[pos + 4:end]))
            except msgspec.ValidationError:
                pass  # a record kind this version does not know
            except msgspec.DecodeError as exc:
                raise RecordingError(f"a damaged record: {exc}") from None
            pos = end
        del buf[:pos]
        return out
