"""What the sync and async clients share: the error, the decoded reply and register lookup through
the register table (built on ``protocol/`` alone)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..protocol import registers as regs
from ..protocol.firmware import NEWEST_PROFILE
from ..protocol.frame import StateBits


class ClientError(RuntimeError):
    """The connection failed or the reply did not match the request."""


@dataclass(frozen=True)
class Response(StateBits):
    """A decoded reply: the state byte's bits and the reply values of the register's layout
    (section 2.1.2); ``tid`` is the transaction id the reply answered."""

    register: int
    state: int
    values: dict[str, Any] = field(default_factory=dict)
    raw: bytes = b""
    tid: int = 0

    def __getitem__(self, key: str) -> Any:
        return self.values[key]


def resolve(register: int | str) -> regs.Register:
    """The table's entry for a register code or name (any case), the manual's first, then those of
    later firmware (in their newest form); :class:`KeyError` if unknown."""
    reg = regs.get(register) if isinstance(register, int) else regs.BY_NAME.get(register.upper())
    if reg is None and isinstance(register, int):
        reg = regs.registers_for(NEWEST_PROFILE).get(register)
    if reg is None:
        raise KeyError(f"unknown register {register!r}")
    return reg


def method_name(reg: regs.Register) -> str:
    """The client method of a register: its name in lower case (``MOVE_LINE`` -> ``move_line``)."""
    return reg.name.lower()
