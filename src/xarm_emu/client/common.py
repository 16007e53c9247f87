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


def method_name(reg: regs.Register) -> str:
    """The client method of a register: its name in lower case (``MOVE_LINE`` -> ``move_line``)."""
    return reg.name.lower()


def _doc(reg: regs.Register) -> str:
    return (f"Register {reg.code}, {reg.title} (manual {reg.section}).\n\n"
            f"Request: {reg.request.describe()}\nReply: {reg.reply.describe()}\n"
            + (f"\n{reg.doc}\n" if reg.doc else ""))


def add_register_methods(cls: type, asynchronous: bool) -> None:
    """Give ``cls`` one method per register of the table (keyword arguments are the request's
    fields; the result is a :class:`Response` whose ``values`` are the reply's fields), unless the
    class already defines a method of that name (a typed helper)."""
    for reg in regs.REGISTERS.values():
        name = method_name(reg)
        if hasattr(cls, name):
            continue
        code = reg.code
        if asynchronous:
            async def amethod(self: Any, raw: bytes | None = None, _code: int = code,
                              **values: Any) -> Response:
                return await self.call(_code, raw, **values)

            fn: Any = amethod
        else:
            def smethod(self: Any, raw: bytes | None = None, _code: int = code, **values: Any) -> Response:
                return self.call(_code, raw, **values)

            fn = smethod
        fn.__name__ = fn.__qualname__ = name
        fn.__doc__ = _doc(reg)
        setattr(cls, name, fn)
