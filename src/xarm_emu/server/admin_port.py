"""The admin channel's socket: moves bytes between a connection and :mod:`.admin`.

Framing is :class:`~xarm_emu.protocol.admin.LineDecoder` (sans-IO); the requests are checked and
carried out by :func:`.admin.execute`. Loopback peers only (:func:`~xarm_emu.protocol.admin.is_loopback`),
and every request carries the admin token (``"token"``, the file of
:func:`~xarm_emu.protocol.admin_token.admin_token_path`, owner-only), so another local user cannot inject
faults.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import logging
from typing import Any, Protocol

from ..protocol.admin import LineDecoder, LineTooLong, encode_answer, is_loopback, ok, refused
from ..protocol.admin_token import admin_token_path
from .admin import AdminError, AdminTarget, execute

log = logging.getLogger("xarm_emu.admin")


class AdminHost(AdminTarget, Protocol):
    """An admin target that also keeps its admin connections and its clock up to date."""

    admin_clients: set[AdminProtocol]
    #: Every request must carry it (``"token"``); ``None``: none required.
    admin_token: str | None

    def catch_up(self) -> int: ...


class AdminProtocol(asyncio.Protocol):
    """One admin connection: JSON lines in, JSON lines out."""

    def __init__(self, server: AdminHost) -> None:
        self.server = server
        self.transport: asyncio.Transport | None = None
        self.decoder = LineDecoder()

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]  # uvloop's transports are not subclasses
        peer = transport.get_extra_info("peername")
        host = str(peer[0]) if peer else ""
        if not is_loopback(host):
            log.warning("admin: refused non-loopback peer %s", host)
            self._answer(refused(f"refused: the admin channel accepts loopback peers only, "
                                 f"not {host or 'unknown'}"))
            transport.close()
            self.transport = None
            return
        self.server.admin_clients.add(self)

    def data_received(self, data: bytes) -> None:
        if self.transport is None:
            return
        for item in self.decoder.feed(data):
            if self.transport is None:
                return
            if isinstance(item, LineTooLong):
                self._answer(refused(str(item)))
                self.transport.close()
                self.transport = None
                return
            self._answer(refused(str(item)) if isinstance(item, ValueError) else self.handle(item))

    def handle(self, request: dict[str, Any]) -> dict[str, Any]:
        """The answer to one request object."""
        expected = getattr(self.server, "admin_token", None)  # a host without one requires none
        if expected is not None:
            token = request.pop("token", None)
            if not isinstance(token, str) or not hmac.compare_digest(token, expected):
                log.warning("admin: refused a request without the right token (%s)", request.get("cmd"))
                return refused(f"refused: {'wrong' if token else 'no'} admin token; clients read it from "
                               f"{admin_token_path()} (readable by the emulator's user only)")
        else:
            request.pop("token", None)
        try:
            # the arm's lock (an EmulatorServer's): no report frame is made half-way through
            with getattr(self.server, "lock", None) or contextlib.nullcontext():
                self.server.catch_up()  # the fault lands after every control period that has elapsed
                message = execute(self.server, request)
        except AdminError as exc:
            return refused(str(exc))
        log.info("admin: %s", message)
        return ok(message)

    def _answer(self, obj: dict[str, Any]) -> None:
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(encode_answer(obj))

    def connection_lost(self, exc: Exception | None) -> None:
        self.transport = None
        self.server.admin_clients.discard(self)
