"""Standard Modbus PDUs read back as plain values, for the wire trace and its replay (sans-IO).

:func:`describe` names what one request PDU asked (function code, address, count, the values it
writes) and what its reply PDU answered (the values read, or the exception code), from the byte
layouts of the Modbus application protocol for the function codes the map answers (01-06, 0F, 10,
16, 17). It never raises: what cannot be read is left out and ``malformed`` says so.
"""

from __future__ import annotations

import struct
from typing import Any

_ADDR_COUNT = struct.Struct(">HH")


def _bits(data: bytes, count: int) -> list[int]:
    return [(data[i // 8] >> (i % 8)) & 1 for i in range(min(count, len(data) * 8))]


def _words(data: bytes) -> list[int]:
    return list(struct.unpack(f">{len(data) // 2}H", data[: len(data) // 2 * 2]))


def _request(fc: int, body: bytes) -> dict[str, Any]:
    if fc in (0x01, 0x02, 0x03, 0x04):
        address, count = _ADDR_COUNT.unpack_from(body)
        return {"address": address, "count": count}
    if fc == 0x05:
        address, value = _ADDR_COUNT.unpack_from(body)
        return {"address": address, "count": 1, "values": [1 if value == 0xFF00 else 0]}
    if fc == 0x06:
        address, value = _ADDR_COUNT.unpack_from(body)
        return {"address": address, "count": 1, "values": [value]}
    if fc == 0x0F:
        address, count = _ADDR_COUNT.unpack_from(body)
        return {"address": address, "count": count, "values": _bits(body[5:], count)}
    if fc == 0x10:
        address, count = _ADDR_COUNT.unpack_from(body)
        return {"address": address, "count": count, "values": _words(body[5:])}
    if fc == 0x16:
        address, and_mask, or_mask = struct.unpack_from(">HHH", body)
        return {"address": address, "count": 1, "and_mask": and_mask, "or_mask": or_mask}
    if fc == 0x17:
        address, count, write_address, write_count = struct.unpack_from(">HHHH", body)
        return {"address": address, "count": count, "write_address": write_address,
                "write_count": write_count, "write_values": _words(body[9:])}
    return {}


def _reply(fc: int, body: bytes, count: int | None) -> dict[str, Any]:
    if fc & 0x80:
        return {"exception": body[0]}
    if fc in (0x01, 0x02):
        return {"exception": None, "values": _bits(body[1:1 + body[0]], count or body[0] * 8)}
    if fc in (0x03, 0x04, 0x17):
        return {"exception": None, "values": _words(body[1:1 + body[0]])}
    return {"exception": None}


def describe(request: bytes, reply: bytes) -> dict[str, Any]:
    """What ``request`` asked and ``reply`` answered (module docstring): ``function``, ``address``,
    ``count``, ``values`` (written, for a write; read, for a read: ``read`` then), ``exception``."""
    out: dict[str, Any] = {"function": request[0] if request else None}
    malformed = False
    try:
        out.update(_request(request[0], request[1:]))
    except (struct.error, IndexError):
        malformed = True
    written = out.pop("values", None)
    if written is not None:
        out["values"] = written
    try:
        if reply:
            answered = _reply(reply[0], reply[1:], out.get("count"))
            read = answered.pop("values", None)
            out.update(answered)
            if read is not None:
                out["read"] = read
    except (struct.error, IndexError):
        malformed = True
    if malformed:
        out["malformed"] = True
    return out
