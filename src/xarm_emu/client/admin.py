"""Client of the emulator's admin channel (fault injection; protocol in :mod:`xarm_emu.protocol.admin`).

The admin channel listens on loopback at the command port + 10000 unless the server was started
with ``--admin-port``; :func:`admin_port` derives it the same way. Every request carries the admin
token, read from :func:`admin_token_path` (``admin-token`` in the per-user configuration directory,
or ``$XARM_EMU_ADMIN_TOKEN_FILE``) unless given.
"""

from __future__ import annotations

import json
import socket
from typing import Any

from ..protocol.admin import ADMIN_PORT_OFFSET, derive_admin_port
from ..protocol.admin_token import admin_token_path, read_admin_token
from .common import ClientError

__all__ = ["ADMIN_PORT_OFFSET", "AdminClient", "AdminRefused", "admin_port", "admin_token_path"]


class AdminRefused(ClientError):
    """The emulator refused an admin request (the message says why); nothing changed."""


def admin_port(command_port: int, explicit: int | None = None) -> int:
    """The admin port: ``explicit`` if given, else ``command_port`` + 10000."""
    return explicit if explicit is not None else derive_admin_port(command_port)


class AdminClient:
    """One connection to the admin channel; ``request("error", code="C31")`` -> message."""

    def __init__(self, host: str = "127.0.0.1", port: int = 502 + ADMIN_PORT_OFFSET,
                 timeout: float = 5.0, token: str | None = None) -> None:
        #: Sent with every request; by default the per-user token file's (``admin_token_path``).
        self.token = token if token is not None else read_admin_token()
        self._sock = socket.create_connection((host, port), timeout=timeout)
        self._file = self._sock.makefile("rb")

    def close(self) -> None:
        self._file.close()
        self._sock.close()

    def __enter__(self) -> AdminClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def send(self, obj: dict[str, Any]) -> dict[str, Any]:
        """Send one request object and return the answer object as is."""
        if self.token is not None and "token" not in obj:
            obj = {**obj, "token": self.token}
        self._sock.sendall(json.dumps(obj).encode() + b"\n")
        line = self._file.readline()
        if not line:
            raise ClientError("admin connection closed by the emulator")
        answer = json.loads(line)
        if not isinstance(answer, dict):
            raise ClientError(f"unexpected admin answer {line!r}")
        return answer

    def request(self, cmd: str, **args: Any) -> str:
        """Send ``cmd`` with its arguments; the emulator's message, or :class:`AdminRefused`."""
        answer = self.send({"cmd": cmd, **args})
        if not answer.get("ok"):
            raise AdminRefused(str(answer.get("error", "refused")))
        return str(answer.get("message", ""))
