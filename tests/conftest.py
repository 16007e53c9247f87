"""Shared fixtures: an in-process emulator, a server on free ports, and the official SDK pointed at it.

Servers bind port 0 on loopback and publish their ports in ``server.ports``. The SDK has no port
argument (research note section 0.1): ``sdk_arm`` sets ``XCONF.SocketConf`` for the duration of a
test and maps our report ports onto the SDK's report structures, which it picks by the standard
port numbers 30001/30002/30003.

Tests in the server, client, CLI and SDK files are checked for leaks: every thread they start must
end and every socket they open must be closed by the end of the test.
"""

from __future__ import annotations

import contextlib
import os
import socket
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings

from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerConfig, ServerThread
from xarm_emu.viewer.app import attach_viewer

# `make test` is deterministic: the same examples on every run, so CI never fails on a draw a developer
# could not see. `make fuzz` explores new random examples (HYPOTHESIS_PROFILE=explore).
settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

_LEAK_CHECKED = ("test_server_", "test_client_", "test_cli_", "test_sdk_")


def _open_sockets() -> set[str]:
    """Inode names of this process's open sockets (Linux); empty where /proc is missing."""
    out = set()
    with contextlib.suppress(OSError):
        for fd in os.listdir("/proc/self/fd"):
            with contextlib.suppress(OSError):
                target = os.readlink(f"/proc/self/fd/{fd}")
                if target.startswith("socket:"):
                    out.add(target)
    return out


@pytest.fixture(autouse=True)
def _no_leaks(request: pytest.FixtureRequest) -> Iterator[None]:
    """Fail a server/client/CLI/SDK test that leaves threads or sockets behind."""
    if not request.module.__name__.rsplit(".", 1)[-1].startswith(_LEAK_CHECKED):
        yield
        return
    threads = set(threading.enumerate())
    sockets = _open_sockets()
    yield
    deadline = time.monotonic() + 3.0  # the SDK's threads notice a closed socket within ~1 s
    while True:
        extra_threads = [t for t in threading.enumerate() if t not in threads and t.is_alive()]
        extra_sockets = _open_sockets() - sockets
        if not extra_threads and not extra_sockets:
            return
        if time.monotonic() > deadline:
            break
        time.sleep(0.05)
    assert not extra_threads, f"threads left running: {[t.name for t in extra_threads]}"
    assert not extra_sockets, f"{len(extra_sockets)} sockets left open"


@pytest.fixture
def emu(tmp_path: Path) -> Emulator:
    """An in-process xArm6 with its saved configuration in a temporary directory."""
    return Emulator(6, config_dir=tmp_path / "config")


ServerFactory = Callable[..., ServerThread]


@pytest.fixture
def make_server(tmp_path: Path) -> Iterator[ServerFactory]:
    """``make_server(model=6, speed=1.0, admin=False, **config)``: a started ServerThread on free ports."""
    started: list[ServerThread] = []

    def factory(model: int = 6, *, emulator: Emulator | None = None, use_uvloop: bool = False,
                **config: Any) -> ServerThread:
        emu = emulator or Emulator(model, config_dir=tmp_path / f"config{len(started)}")
        cfg = ServerConfig(**{"host": "127.0.0.1", "port": 0, "normal_port": 0, "rich_port": 0,
                              "develop_port": 0, **config})
        st = ServerThread(emu, cfg, use_uvloop=use_uvloop, compose=(attach_viewer,)).start()
        started.append(st)
        return st

    yield factory
    for st in started:
        st.stop()


@pytest.fixture
def server_with_derived_admin_port(make_server: ServerFactory) -> ServerThread:
    """A server whose admin channel sits on its command port + 10000 (the default rule): tries free
    command ports until that pair is free too."""
    for _ in range(20):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            p = s.getsockname()[1]
        if p + 10000 > 65535:
            continue
        try:
            return make_server(port=p, admin=True)
        except OSError:
            continue
    pytest.skip("no free pair of command and admin ports")


@pytest.fixture
def server(make_server: ServerFactory) -> ServerThread:
    """A real-time xArm6 server with the admin channel on (ports in ``server.ports``)."""
    return make_server(admin=True)


@pytest.fixture
def sdk_arm() -> Iterator[Callable[..., Any]]:
    """``sdk_arm(server, report_type='rich', **kwargs)``: the official XArmAPI connected to ``server``
    through :func:`xarm_emu.testing.sdk_pointed_at`; disconnected and restored at teardown."""
    from xarm.wrapper import XArmAPI

    from xarm_emu.testing import sdk_pointed_at

    arms: list[Any] = []
    with contextlib.ExitStack() as stack:

        def factory(st: ServerThread, report_type: str = "rich", **kwargs: Any) -> Any:
            stack.enter_context(sdk_pointed_at(st))
            kwargs.setdefault("forbid_uds", True)
            arm = XArmAPI("127.0.0.1", report_type=report_type, **kwargs)
            arms.append(arm)
            return arm

        yield factory
        for arm in arms:
            with contextlib.suppress(Exception):
                arm.disconnect()
