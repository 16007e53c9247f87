"""What the sync and async clients share: request building and reply decoding
through the register table (built on ``protocol/`` alone)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..protocol import registers as regs
from ..protocol import reports
from ..protocol.frame import Reply, StateBits, encode_request

REPORT_DECODERS = {
    "develop": (reports.DEVELOP_PORT, reports.decode_develop),
    "normal": (reports.NORMAL_PORT, reports.decode_normal),
    "rich": (reports.RICH_PORT, reports.decode_rich),
}


class ClientError(RuntimeError):
    """The connection failed or the reply did not match the request."""


@dataclass(frozen=True)
class Response(StateBits):
    """A decoded reply: the state byte's bits and the reply values of the register's layout."""

    register: int
    state: int
    values: dict[str, Any] = field(default_factory=dict)
    raw: bytes = b""

    def __getitem__(self, key: str) -> Any:
        return self.values[key]


def resolve(register: int | str) -> regs.Register:
    reg = regs.get(register) if isinstance(register, int) else regs.BY_NAME.get(register.upper())
    if reg is None:
        raise KeyError(f"unknown register {register!r}")
    return reg


def build(tid: int, register: int | str, values: dict[str, Any],
          raw: bytes | None = None) -> tuple[regs.Register, bytes]:
    reg = resolve(register)
    params = raw if raw is not None else reg.request.encode(values)
    return reg, encode_request(tid, reg.code, params)


def parse(reg: regs.Register, reply: Reply) -> Response:
    if reply.register != reg.code:
        raise ClientError(f"reply for register {reply.register}, expected {reg.code}")
    values: dict[str, Any] = {}
    if reply.params and reg.reply.accepts(len(reply.params)):
        values = reg.reply.decode(reply.params)
    return Response(reg.code, reply.state, values, reply.params)
