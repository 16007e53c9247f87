"""The admin channel's wire protocol (fault injection and sensor play, issue 5 item 5).

Line-based JSON over TCP: one request object per line with ``cmd`` and its arguments, one answer
object per line (``{"ok": true, "message": ...}`` or ``{"ok": false, "error": ...}``). The server
side is :mod:`xarm_emu.server.admin` (commands and their effects), the client side
:mod:`xarm_emu.client.admin`. Sans-IO: constants and the port rule only.
"""

from __future__ import annotations

import ipaddress

#: The admin port is the command port plus this offset unless given explicitly.
ADMIN_PORT_OFFSET = 10000
#: Admin request lines longer than this are refused and the connection closed.
MAX_LINE = 4096
#: Longest accepted report pause or reply delay, seconds.
MAX_SECONDS = 3600.0

COMMANDS = ("estop", "error", "warning", "servo-error", "gripper-error", "end-module-lost",
            "collision", "report-pause", "reply-delay", "drop-clients", "clear", "set-input", "status",
            "step")
INPUT_KINDS = ("cgpio", "tgpio", "analog", "tool-analog", "vacuum-object")


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
