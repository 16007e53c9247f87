"""Register maps of Modbus-RTU slaves: each address a declared field, and one function pair that
serves reads and writes from the map, in the manner of a Modbus datastore (the devices on the tool
and control box RS-485 that register 124 reaches, manual section 2.1.4).

A map is ``address -> Reg``: the field the register holds, its access (``"r"``, ``"w"``, ``"rw"``),
the engineering units per count (``scale``, ``unit``), the values a write accepts (``range``, and a
``keep`` value that leaves the field as it is) and how the device gives or takes the value
(``get``/``put``, by default the device's attribute of the field's name). :func:`read_registers` and
:func:`write_registers` turn a request into those calls and answer an address the map lacks, or a
read of a write-only register, with exception 2 (illegal data address) and a value outside the range
with exception 3 (illegal data value).

Sans-IO: a device's behaviour stays in its own methods, which ``put``/``commit`` call.
"""

from __future__ import annotations

import dataclasses
import functools
import operator
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from . import rtu


@dataclass(frozen=True, slots=True)
class Reg:
    """One holding register of a device (a register of a wider field is one ``Reg`` per word)."""

    #: What the register holds, in the device's vocabulary (``speed``, ``target[hi]``).
    field: str
    #: ``"r"`` (a write is exception 2), ``"w"`` (a read is exception 2) or ``"rw"``.
    access: str = "r"
    #: The device's value: by default its attribute ``field``, as an int (masked to 16 bits).
    get: Callable[[Any], int] | None = None
    #: Take a written value (a block's values as a tuple): by default set the attribute ``field``.
    put: Callable[[Any, Any], None] | None = None
    #: The raw values a write accepts; any other is exception 3 (``None``: the device decides).
    range: tuple[int, int] | None = None
    #: A raw value that leaves the field unchanged (no ``put``), whatever the range.
    keep: int | None = None
    #: Engineering units per count, and their name (documentation of the map).
    scale: float = 1.0
    unit: str = ""
    #: Runs once after a write request wrote its registers (a value that spans two registers).
    commit: Callable[[Any], None] | None = None
    #: Registers a write must give together from here (``put`` then takes them all as a tuple);
    #: a write of fewer, or starting inside the block, is exception 2.
    block: int = 1

    def value(self, device: Any) -> int:
        """The register's raw value now (16 bits)."""
        get = self.get or operator.attrgetter(self.field)
        return int(get(device)) & 0xFFFF

    def accept(self, value: Any) -> bool:
        """Whether a write of raw ``value`` passes the range (a ``keep`` value always does)."""
        return self.range is None or value == self.keep or self.range[0] <= value <= self.range[1]

    def store(self, device: Any, value: Any) -> None:
        """Give ``device`` the written value (nothing for the ``keep`` value)."""
        if self.keep is not None and value == self.keep:
            return
        if self.put is not None:
            self.put(device, value)
        else:
            setattr(device, self.field, value)


RegisterMap = Mapping[int, Reg]


def read_registers(regmap: RegisterMap, device: Any, address: int, count: int, stride: int = 1) -> list[int]:
    """Function 0x03: ``count`` registers from ``address`` (``stride`` apart: a map that numbers
    bytes); an address without a readable register is exception 2."""
    out = []
    for a in range(address, address + count * stride, stride):
        reg = regmap.get(a)
        if reg is None or "r" not in reg.access:
            raise rtu.RtuError(rtu.ILLEGAL_ADDRESS)
        out.append(reg.value(device))
    return out


def _plan(regmap: RegisterMap, address: int, values: Sequence[int], stride: int,
          check_values: bool) -> list[tuple[Reg, Any]]:
    """The registers a write request reaches, each with its value (a block's values as a tuple);
    any address without a writable register, or a block not written whole, is exception 2, and with
    ``check_values`` a value outside its register's range is exception 3, in the order they come."""
    plan: list[tuple[Reg, Any]] = []
    i = 0
    while i < len(values):
        reg = regmap.get(address + i * stride)
        if reg is None or "w" not in reg.access or i + reg.block > len(values):
            raise rtu.RtuError(rtu.ILLEGAL_ADDRESS)
        v = values[i] if reg.block == 1 else tuple(values[i:i + reg.block])
        if check_values and not reg.accept(v):
            raise rtu.RtuError(rtu.ILLEGAL_VALUE)
        plan.append((reg, v))
        i += reg.block
    return plan


def write_registers(regmap: RegisterMap, device: Any, address: int, values: Sequence[int], *,
                    stride: int = 1, atomic: bool = False) -> None:
    """Functions 0x06/0x10: write ``values`` from ``address``. Every address is checked first
    (exception 2, nothing changed); then each register in turn checks its range (exception 3) and
    takes its value, and the commits of the registers written run once, in order. ``atomic``: each
    register checks its address and then its range before any takes its value, so a refused write
    changes nothing."""
    commits: list[Callable[[Any], None]] = []
    for reg, v in _plan(regmap, address, values, stride, check_values=atomic):
        if not reg.accept(v):
            raise rtu.RtuError(rtu.ILLEGAL_VALUE)
        reg.store(device, v)
        if reg.commit is not None and reg.commit not in commits:
            commits.append(reg.commit)
    for commit in commits:
        commit(device)


# --- building maps ----------------------------------------------------------------------------------


def _s32_word(device: Any, *, value: Callable[[Any], float], counts: float, word: int) -> int:
    return rtu.s32_words(int(round(value(device) * counts)))[word]


def s32(address: int, field: str, *, value: Callable[[Any], float] | None = None, counts: float = 1.0,
        unit: str = "", access: str = "r", put: Callable[..., None] | None = None,
        commit: Callable[[Any], None] | None = None, whole: bool = False) -> dict[int, Reg]:
    """A signed 32-bit field in two registers, high word first (positions of the grippers and the
    linear track): ``value`` (default: the attribute ``field``) in ``unit`` times ``counts`` counts
    per unit, rounded. A writable one takes each word with ``put(device, value, word=0 or 1)`` and
    runs ``commit`` once after the request; ``whole``: it takes both words at once,
    ``put(device, (hi, lo))``, and a write of one of them is exception 2."""
    get = value or operator.attrgetter(field)
    out = {address + w: Reg(f"{field}[{'hi' if w == 0 else 'lo'}]", access if w == 0 or not whole else "r",
                            get=functools.partial(_s32_word, value=get, counts=counts, word=w),
                            put=None if put is None or whole else functools.partial(put, word=w),
                            scale=1.0 / counts, unit=unit, commit=commit)
           for w in (0, 1)}
    if whole:
        out[address] = dataclasses.replace(out[address], put=put, block=2)
    return out


def _item(device: Any, *, field: str, index: int) -> Any:
    return operator.attrgetter(field)(device)[index]


def _set_item(device: Any, value: int, *, field: str, index: int) -> None:
    operator.attrgetter(field)(device)[index] = value


def _constant(device: Any, *, value: int) -> int:
    return value


def constants(address: int, field: str, values: Sequence[int]) -> dict[int, Reg]:
    """Read-only registers holding fixed values from ``address`` (a version, a serial number)."""
    return {address + i: Reg(f"{field}[{i}]", get=functools.partial(_constant, value=v))
            for i, v in enumerate(values)}


def items(address: int, field: str, count: int, *, access: str = "r", stride: int = 1,
          **kwargs: Any) -> dict[int, Reg]:
    """``count`` registers, ``stride`` apart, holding the items of the device's sequence ``field``
    (a dotted attribute path); a writable one sets the item."""
    return {address + stride * i: Reg(f"{field}[{i}]", access,
                                      get=functools.partial(_item, field=field, index=i),
                                      put=functools.partial(_set_item, field=field, index=i)
                                      if "w" in access else None, **kwargs)
            for i in range(count)}


def entries(field: str, addresses: Iterable[int], *, access: str = "r") -> dict[int, Reg]:
    """Registers at ``addresses`` holding the entries of the device's mapping ``field`` under the same
    keys (stored parameters, by address)."""
    return {a: Reg(f"{field}[{a:#06x}]", access, get=functools.partial(_item, field=field, index=a),
                   put=functools.partial(_set_item, field=field, index=a) if "w" in access else None)
            for a in addresses}
