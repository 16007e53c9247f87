"""The admin channel's wire protocol (fault injection, sensor play and checkpoints).

Line-based JSON over TCP: one request object per line with ``cmd`` and its arguments, one answer
object per line (``{"ok": true, "message": ...}`` or ``{"ok": false, "error": ...}``). The server
side is :mod:`xarm_emu.server.admin` (commands and their effects) behind
:mod:`xarm_emu.server.admin_port` (the socket), the client side :mod:`xarm_emu.client.admin`.
Sans-IO: constants, the port rule and the line framing (:class:`LineDecoder`, :func:`encode_answer`),
no sockets.
"""

from __future__ import annotations

import ipaddress
import json
from typing import Any

#: The admin port is the command port plus this offset unless given explicitly.
ADMIN_PORT_OFFSET = 10000
#: Admin request lines longer than this are refused and the connection closed.
MAX_LINE = 4096
#: Longest accepted report pause or reply delay, seconds.
MAX_SECONDS = 3600.0

COMMANDS = ("estop", "error", "warning", "servo-error", "gripper-error", "track-error", "end-module-lost",
            "collision", "report-pause", "reply-delay", "drop-clients", "clear", "set-input", "status",
            "step", "ft-error", "ft-noise", "payload", "scene",
            "checkpoint-save", "checkpoint-restore", "checkpoint-list",
            "scene-objects", "scene-place", "scene-reset", "scene-add", "scene-remove")
#: Longest checkpoint name (``checkpoint-save``/``checkpoint-restore``).
MAX_NAME = 64
INPUT_KINDS = ("cgpio", "tgpio", "analog", "tool-analog", "vacuum-object", "gripper-object", "ft")
#: Frames an external wrench (``set-input`` kind ``ft``) may be given in.
WRENCH_FRAMES = ("tool", "base")


def derive_admin_port(command_port: int) -> int:
    """The default admin port for a command port (502 -> 10502)."""
    port = command_port + ADMIN_PORT_OFFSET
    if not 0 < port <= 0xFFFF:
        raise ValueError(f"no default admin port for command port {command_port}: give --admin-port")
    return port


def is_loopback(host: str) -> bool:
    """True for a loopback address (127.0.0.0/8, ::1, IPv4-mapped loopback); names are not resolved."""
    try:
        addr = ipaddress.ip_address(host.split("%", 1)[0])
    except ValueError:
        return False
    if isinstance(addr, ipaddress.IPv6Address) and addr.ipv4_mapped is not None:
        addr = addr.ipv4_mapped
    return addr.is_loopback


def admin_host(host: str) -> str:
    """Where the admin channel of an arm served on ``host`` listens: that address when it is a loopback
    one (so arms on 127.0.0.1, 127.0.0.2, ... each have theirs on the same port), else 127.0.0.1."""
    return host if is_loopback(host) else "127.0.0.1"


def checkpoint_name(value: Any) -> str:
    """A checkpoint name as sent (stripped); ValueError unless a non-empty string of at most
    :data:`MAX_NAME` characters."""
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"checkpoint name must be a non-empty string, got {value!r}")
    name = value.strip()
    if len(name) > MAX_NAME:
        raise ValueError(f"checkpoint name longer than {MAX_NAME} characters")
    return name


class LineTooLong(ValueError):
    """A request line exceeded :data:`MAX_LINE`; the connection is to be closed after the answer."""


#: The answer to a line that is not one JSON object.
NOT_AN_OBJECT = "not a JSON object line"


class LineDecoder:
    """Sans-IO JSON-lines framing of admin requests (bytes in, requests out; no sockets).

    :meth:`feed` takes bytes as they arrive and returns, for each complete non-blank line, its
    request object or a :class:`ValueError` saying why it is not one. A partial line longer than
    :data:`MAX_LINE` gives a :class:`LineTooLong` and the decoder accepts nothing more.
    """

    def __init__(self, max_line: int = MAX_LINE) -> None:
        self.max_line = max_line
        self.closed = False
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[dict[str, Any] | ValueError]:
        """The requests (or errors) of every line completed by ``data``, in order."""
        if self.closed:
            return []
        self._buf += data
        out: list[dict[str, Any] | ValueError] = []
        while b"\n" in self._buf:
            line, _, rest = bytes(self._buf).partition(b"\n")
            self._buf = bytearray(rest)
            if line.strip():
                out.append(decode_request(line))
        if len(self._buf) > self.max_line:
            self._buf.clear()
            self.closed = True
            out.append(LineTooLong(f"request line longer than {self.max_line} bytes"))
        return out


def decode_request(line: bytes) -> dict[str, Any] | ValueError:
    """One request line as its object, or a :class:`ValueError` when it is not a JSON object."""
    try:
        request = json.loads(line)
    except (ValueError, UnicodeDecodeError):
        return ValueError(NOT_AN_OBJECT)
    if not isinstance(request, dict):
        return ValueError(NOT_AN_OBJECT)
    return request


def encode_answer(answer: dict[str, Any]) -> bytes:
    """One answer object as its line (``{"ok": true, "message": ...}`` or ``{"ok": false, ...}``)."""
    return json.dumps(answer).encode() + b"\n"


def ok(message: str) -> dict[str, Any]:
    """The answer to a request that was carried out."""
    return {"ok": True, "message": message}


def refused(error: str) -> dict[str, Any]:
    """The answer to a refused request (nothing changed)."""
    return {"ok": False, "error": error}
