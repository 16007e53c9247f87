"""What every command of ``xarm-emu`` shares: the consoles, the one-line exit for a mistake, the port
and address checks, the options that address an emulator's admin channel and the admin request itself.

Exit status: 2 for a usage or input mistake, 1 for a runtime failure, each with one line on stderr.
"""

from __future__ import annotations

from typing import Annotated, Any, NoReturn

import typer
from rich.console import Console

# Markup off: messages show square brackets as written (``xarm-emu[view]``, ``[[arm]]``).
console = Console(markup=False, highlight=False)
err_console = Console(stderr=True, markup=False, highlight=False, soft_wrap=True)

HostOpt = Annotated[str, typer.Option(help="Emulator address (the admin channel is loopback only).")]
PortOpt = Annotated[int, typer.Option(help="The emulator's command port; the admin port is this + 10000.")]
AdminPortOpt = Annotated[int | None, typer.Option(help="Admin channel port, if the server was started "
                                                       "with --admin-port.")]


def user_error(message: str) -> NoReturn:
    """One line on stderr and exit 2: a bad option, found before any port opens."""
    err_console.print(message)
    raise typer.Exit(2)


def check_port(name: str, value: int | None) -> None:
    if value is not None and not 0 <= value <= 65535:
        user_error(f"{name}: a port is 0..65535 (0: any free port), got {value}")


def check_host(name: str, host: str) -> str | None:
    """None if ``host`` is an address of this machine that a server can bind, else why not."""
    import socket

    try:
        infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError) as exc:
        return f"{name}: cannot resolve {host!r} ({getattr(exc, 'strerror', None) or exc})"
    family, _, _, _, addr = infos[0]
    try:
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.bind((addr[0], 0, *addr[2:]))
    except OSError as exc:
        return (f"{name}: {host!r} is not an address of this machine ({exc.strerror or exc}); "
                "use 127.0.0.1, 0.0.0.0 or one of its own addresses")
    return None


def admin(host: str, port: int, admin_port: int | None, cmd: str, *, refused_exit: int = 2,
          **args: Any) -> str:
    """Send one admin request, print the emulator's answer and return it; exit ``refused_exit`` when
    it refuses an argument, 1 when there is no channel or it refuses the token."""
    from ..client import ClientError
    from ..client.admin import AdminClient, AdminRefused
    from ..client.admin import admin_port as derive
    from ..protocol.admin import admin_host

    check_port("--port", port)
    check_port("--admin-port", admin_port)
    try:
        aport = derive(port, admin_port)
    except ValueError as exc:
        err_console.print(str(exc))
        raise typer.Exit(2) from None
    host = admin_host(host)  # the admin channel is on loopback (protocol/admin.py)
    try:
        with AdminClient(host, aport, timeout=3.0) as a:
            message = a.request(cmd, **args)
    except AdminRefused as exc:
        err_console.print(f"refused: {exc}")
        raise typer.Exit(1 if "admin token" in str(exc) else refused_exit) from None
    except (OSError, ClientError) as exc:
        err_console.print(f"cannot reach the admin channel at {host}:{aport} ({exc}); start the emulator "
                          "with `xarm-emu serve --admin` and run this on the same machine")
        raise typer.Exit(1) from None
    if cmd not in ("checkpoint-list", "scene-objects"):
        console.print(message)
    return message
