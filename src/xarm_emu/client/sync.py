"""Blocking client for the command port and the report ports."""

from __future__ import annotations

import socket
import struct
from collections.abc import Iterator
from typing import Any

from ..protocol.frame import FrameDecoder, Reply
from ..protocol.reports import ReportSnapshot
from .common import REPORT_DECODERS, ClientError, Response, add_register_methods, build, parse


class Client:
    """A connection to an xArm control box (real or emulated) on its command port.

    ``client.call("GET_STATE")`` or ``client.call(13)`` sends one request and returns a
    :class:`Response`; helper methods cover the common registers.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 502, timeout: float = 5.0) -> None:
        self.host = host
        self.port = port
        self.timeout = timeout
        self._sock = socket.create_connection((host, port), timeout=timeout)
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._decoder = FrameDecoder(replies=True)
        self._pending: list[Reply] = []
        self._tid = 0

    def close(self) -> None:
        self._sock.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def call(self, register: int | str, raw: bytes | None = None, **values: Any) -> Response:
        self._tid = self._tid % 0xFFFF + 1
        reg, frame = build(self._tid, register, values, raw)
        self._sock.sendall(frame)
        while True:
            while self._pending:
                reply = self._pending.pop(0)
                if reply.tid == self._tid:
                    return parse(reg, reply)
            data = self._sock.recv(65536)
            if not data:
                raise ClientError("connection closed by the control box")
            self._pending.extend(self._decoder.feed(data))  # type: ignore[arg-type]

    # -- common registers ---------------------------------------------------------------------
    def get_version(self) -> str:
        return str(self.call(1)["version"])

    def get_state(self) -> int:
        return int(self.call(13)["state"])

    def get_cmdnum(self) -> int:
        return int(self.call(14)["cmdnum"])

    def get_err_warn(self) -> tuple[int, int]:
        r = self.call(15)
        return int(r["error"]), int(r["warning"])

    def get_position(self) -> tuple[float, ...]:
        return tuple(self.call(41)["pose"])

    def get_joints(self) -> tuple[float, ...]:
        return tuple(self.call(42)["joints"])

    def motion_enable(self, enable: bool = True, joint: int = 8) -> Response:
        return self.call(11, joint=joint, enable=int(enable))

    def set_mode(self, mode: int) -> Response:
        return self.call(19, mode=mode)

    def set_state(self, state: int) -> Response:
        return self.call(12, state=state)

    def clean_error(self) -> Response:
        return self.call(16)

    def clean_warn(self) -> Response:
        return self.call(17)


add_register_methods(Client, asynchronous=False)


def subscribe(kind: str = "develop", host: str = "127.0.0.1", port: int | None = None,
              timeout: float = 5.0) -> Iterator[ReportSnapshot]:
    """Iterate over decoded report frames of ``kind`` ('develop', 'normal' or 'rich')."""
    default_port, decode = REPORT_DECODERS[kind]
    with socket.create_connection((host, port or default_port), timeout=timeout) as sock:
        while True:
            head = _recv_exact(sock, 4)
            (size,) = struct.unpack(">I", head)
            body = _recv_exact(sock, size - 4)
            yield decode(head + body)


def _recv_exact(sock: socket.socket, n: int) -> bytes:
    buf = bytearray()
    while len(buf) < n:
        chunk = sock.recv(n - len(buf))
        if not chunk:
            raise ClientError("report connection closed")
        buf += chunk
    return bytes(buf)
