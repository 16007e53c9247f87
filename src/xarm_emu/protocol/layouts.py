"""Declarative byte layouts for register parameters (manual section 2.1.1, 2.1.2).

A :class:`Layout` is an ordered tuple of :class:`Field`. Each field has a wire
type from :data:`TYPES`; byte orders follow section 2.1.2 of the manual:
fp32 and int32 little-endian, u16 (GPIO words) big-endian.

Layouts are pure data: the register table (``registers.py``) is built from
them, and encoding/decoding, docs and the client all read the same objects.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any


class LayoutError(ValueError):
    """Parameter bytes do not fit a layout (the manual's warning 12)."""


@dataclass(frozen=True)
class WireType:
    """One scalar wire type: a struct code and its size in bytes."""

    name: str
    fmt: str  # struct format of one value, with byte order
    size: int
    is_float: bool = False


TYPES: dict[str, WireType] = {
    "u8": WireType("u8", "B", 1),
    "i8": WireType("i8", "b", 1),
    "u16": WireType("u16", ">H", 2),  # GPIO / report integers: big-endian
    "i16": WireType("i16", ">h", 2),
    "u32": WireType("u32", ">I", 4),
    "i32be": WireType("i32be", ">i", 4),  # tool/servo register reads (SDK: '>i')
    "fp32": WireType("fp32", "<f", 4, is_float=True),  # section 2.1.2 note 4
    "i32": WireType("i32", "<i", 4),  # section 2.1.2 note 4 (register 52)
}


@dataclass(frozen=True)
class Field:
    """A named run of ``count`` values of one wire type.

    ``kind`` is a key of :data:`TYPES`, or ``"str"`` (``count`` bytes of
    NUL-padded ASCII) or ``"bytes"`` (``count`` raw bytes). ``count == 1``
    scalars decode to a plain value, longer runs to a tuple.
    """

    name: str
    kind: str
    count: int = 1
    doc: str = ""

    @property
    def size(self) -> int:
        if self.kind in ("str", "bytes"):
            return self.count
        return TYPES[self.kind].size * self.count


@dataclass(frozen=True)
class Layout:
    """An ordered list of fields, optionally with optional tail fields and a
    variable-length raw tail.

    - ``required``: how many leading fields must be present (default: all).
      The SDK sends optional trailing bytes on some registers (for example the
      ``sync`` byte of newer firmware), so a request may stop after any field
      at index ``>= required``.
    - ``rest``: name of a trailing raw-bytes value of any length (register 124
      Modbus-RTU data). ``rest_min`` is its minimum length.
    """

    fields: tuple[Field, ...] = ()
    required: int | None = None
    rest: str | None = None
    rest_min: int = 0

    @property
    def n_required(self) -> int:
        return len(self.fields) if self.required is None else self.required

    @property
    def size(self) -> int:
        """Size in bytes of the full fixed part."""
        return sum(f.size for f in self.fields)

    @property
    def min_size(self) -> int:
        return sum(f.size for f in self.fields[: self.n_required]) + (self.rest_min if self.rest else 0)

    def sizes(self) -> list[int]:
        """Accepted fixed sizes (without a rest tail)."""
        out = []
        total = sum(f.size for f in self.fields[: self.n_required])
        out.append(total)
        for f in self.fields[self.n_required :]:
            total += f.size
            out.append(total)
        return out

    def accepts(self, n: int) -> bool:
        if self.rest is not None:
            return n >= self.size + self.rest_min or (
                self.n_required < len(self.fields) and n in self.sizes()
            )
        return n in self.sizes()

    def decode(self, data: bytes) -> dict[str, Any]:
        """Decode parameter bytes; missing optional fields are absent from the dict."""
        n = len(data)
        if not self.accepts(n):
            raise LayoutError(f"{n} parameter bytes; expected one of {self.sizes()}"
                              + (f" or >= {self.size + self.rest_min} with a raw tail" if self.rest else ""))
        out: dict[str, Any] = {}
        off = 0
        for f in self.fields:
            if off + f.size > n:
                break
            out[f.name] = _decode_field(f, data, off)
            off += f.size
        if self.rest is not None and off == self.size:
            out[self.rest] = bytes(data[off:])
        return out

    def encode(self, values: Mapping[str, Any] | None = None, /, **kw: Any) -> bytes:
        """Encode values; stops at the first optional field that is not given."""
        vals: dict[str, Any] = dict(values or {})
        vals.update(kw)
        parts: list[bytes] = []
        for i, f in enumerate(self.fields):
            if f.name not in vals:
                if i >= self.n_required:
                    break
                raise LayoutError(f"missing value for field {f.name!r}")
            parts.append(_encode_field(f, vals[f.name]))
        else:
            if self.rest is not None:
                parts.append(bytes(vals.get(self.rest, b"")))
        return b"".join(parts)

    def describe(self) -> str:
        """A one-line human description, for docs and the CLI."""
        items = [f"{f.name}:{f.kind}" + (f"[{f.count}]" if f.count != 1 else "") for f in self.fields]
        if self.n_required < len(self.fields):
            items.insert(self.n_required, "|")
        if self.rest:
            items.append(f"{self.rest}:bytes...")
        return " ".join(items) if items else "(none)"


@dataclass(frozen=True)
class OneOf(Layout):
    """Alternative layouts of one register, told apart by their byte count.

    Used where the manual and the SDK send different shapes to the same register
    (for example register 134's one-word and two-word forms, or register 78's
    0..6 tool parameters before the tool type). The sizes of the options must
    not overlap. ``fields`` are the first option's fields.
    """

    options: tuple[Layout, ...] = ()

    def __post_init__(self) -> None:
        seen: set[int] = set()
        for opt in self.options:
            if opt.rest is not None:
                raise ValueError("OneOf options cannot have a raw tail")
            sizes = set(opt.sizes())
            if sizes & seen:
                raise ValueError(f"OneOf options overlap in size: {sorted(sizes & seen)}")
            seen |= sizes
        if self.options and not self.fields:
            object.__setattr__(self, "fields", self.options[0].fields)

    @property
    def n_required(self) -> int:
        return self.options[0].n_required if self.options else 0

    @property
    def size(self) -> int:
        return max((o.size for o in self.options), default=0)

    @property
    def min_size(self) -> int:
        return min((o.min_size for o in self.options), default=0)

    def sizes(self) -> list[int]:
        return sorted({n for o in self.options for n in o.sizes()})

    def accepts(self, n: int) -> bool:
        return any(o.accepts(n) for o in self.options)

    def option_for(self, n: int) -> Layout:
        for o in self.options:
            if o.accepts(n):
                return o
        raise LayoutError(f"{n} parameter bytes; expected one of {self.sizes()}")

    def decode(self, data: bytes) -> dict[str, Any]:
        return self.option_for(len(data)).decode(data)

    def encode(self, values: Mapping[str, Any] | None = None, /, **kw: Any) -> bytes:
        """Encode with the first option that names every given value and has its required ones."""
        vals: dict[str, Any] = dict(values or {})
        vals.update(kw)
        keys = set(vals)
        for o in self.options:
            names = [f.name for f in o.fields]
            if keys <= set(names) and all(n in keys for n in names[: o.n_required]):
                try:
                    return o.encode(vals)
                except LayoutError:
                    continue  # e.g. a value count that fits another option
        raise LayoutError(f"no alternative layout takes the values {sorted(keys)}")

    def describe(self) -> str:
        return " || ".join(o.describe() for o in self.options)


def one_of(*options: Layout) -> OneOf:
    return OneOf(options=tuple(options))


def _decode_field(f: Field, data: bytes, off: int) -> Any:
    if f.kind == "bytes":
        return bytes(data[off : off + f.count])
    if f.kind == "str":
        raw = bytes(data[off : off + f.count])
        return raw.split(b"\0", 1)[0].decode("ascii", "replace")
    t = TYPES[f.kind]
    vals = struct.unpack_from(("<" if t.fmt[0] not in "<>" else t.fmt[0]) + t.fmt.lstrip("<>") * f.count,
                              data, off)
    return vals[0] if f.count == 1 else tuple(vals)


def _encode_field(f: Field, value: Any) -> bytes:
    if f.kind == "bytes":
        raw = bytes(value)
        if len(raw) != f.count:
            raise LayoutError(f"field {f.name!r} needs {f.count} bytes, got {len(raw)}")
        return raw
    if f.kind == "str":
        raw = value.encode("ascii") if isinstance(value, str) else bytes(value)
        if len(raw) > f.count:
            raise LayoutError(f"field {f.name!r} longer than {f.count} bytes")
        return raw.ljust(f.count, b"\0")
    t = TYPES[f.kind]
    if f.count == 1 and isinstance(value, (tuple, list)):
        if len(value) != 1:
            raise LayoutError(f"field {f.name!r} needs 1 value, got {len(value)}")
        value = value[0]
    try:
        seq = (value,) if f.count == 1 else tuple(value)
    except TypeError as exc:
        raise LayoutError(f"field {f.name!r} needs {f.count} values") from exc
    if len(seq) != f.count:
        raise LayoutError(f"field {f.name!r} needs {f.count} values, got {len(seq)}")
    order = t.fmt[0] if t.fmt[0] in "<>" else "<"
    code = t.fmt.lstrip("<>")
    try:
        if t.is_float:
            return struct.pack(order + code * f.count, *(float(v) for v in seq))
        return struct.pack(order + code * f.count, *(int(v) for v in seq))
    except (struct.error, TypeError, ValueError, OverflowError) as exc:
        raise LayoutError(f"field {f.name!r}: {exc}") from exc


def all_within(values: Mapping[str, Any], limit: float, *, inf_unchanged: bool = False) -> bool:
    """True when every float in decoded values is finite and no larger than ``limit`` in magnitude.

    ``inf_unchanged`` also lets +inf through (``FirmwareProfile.inf_unchanged``: "keep this component" in
    registers 21/23/83); NaN, -inf and finite values beyond ``limit`` are still refused.
    """
    for v in values.values():
        seq = v if isinstance(v, tuple) else (v,)
        for x in seq:
            if isinstance(x, float) and not (math.isfinite(x) and abs(x) <= limit):
                if inf_unchanged and x == math.inf:
                    continue
                return False
    return True


# Short constructors used by the register table.
def u8(name: str, doc: str = "") -> Field:
    return Field(name, "u8", 1, doc)


def u16(name: str, doc: str = "", count: int = 1) -> Field:
    return Field(name, "u16", count, doc)


def fp32(name: str, count: int = 1, doc: str = "") -> Field:
    return Field(name, "fp32", count, doc)


def i32(name: str, count: int = 1, doc: str = "") -> Field:
    return Field(name, "i32", count, doc)


EMPTY = Layout()
