"""Shared fixtures: an in-process emulator, a server on free ports, and the official SDK pointed at it.

Servers bind port 0 on loopback and publish their ports in ``server.ports``. The SDK has no port
argument (it reads them from ``XCONF.SocketConf``): ``sdk_arm`` sets ``XCONF.SocketConf`` for the
duration of a test and maps our report ports onto the SDK's report structures, which it picks by the standard
port numbers 30001/30002/30003.

Tests in the server, client, CLI and SDK files are checked for leaks: every thread they start must
end and every socket they open must be closed by the end of the test (server, client and CLI files)
or of the module (SDK files, whose tests share servers and arms where state allows).
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
_SDK = "test_sdk_"


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


def _module_name(request: pytest.FixtureRequest) -> str:
    return str(request.module.__name__).rsplit(".", 1)[-1]


def _assert_no_leaks(threads: set[threading.Thread], sockets: set[str], where: str) -> None:
    """Wait up to 3 s for every thread not in ``threads`` to end and every socket not in ``sockets``
    to close (the SDK's threads notice a closed socket within about 2 s), then fail on what is left."""
    deadline = time.monotonic() + 3.0
    while True:
        extra_threads = [t for t in threading.enumerate() if t not in threads and t.is_alive()]
        extra_sockets = _open_sockets() - sockets
        if not extra_threads and not extra_sockets:
            return
        if time.monotonic() > deadline:
            break
        time.sleep(0.05)
    assert not extra_threads, f"threads left running by {where}: {[t.name for t in extra_threads]}"
    assert not extra_sockets, f"{len(extra_sockets)} sockets left open by {where}"


@pytest.fixture(autouse=True)
def _no_leaks(request: pytest.FixtureRequest) -> Iterator[None]:
    """Fail a server/client/CLI test that leaves threads or sockets behind. SDK tests are checked per
    module instead (:func:`_no_leaks_in_sdk_module`)."""
    name = _module_name(request)
    if not name.startswith(_LEAK_CHECKED) or name.startswith(_SDK):
        yield
        return
    threads = set(threading.enumerate())
    sockets = _open_sockets()
    yield
    _assert_no_leaks(threads, sockets, request.node.nodeid)


@pytest.fixture(scope="module", autouse=True)
def _no_leaks_in_sdk_module(request: pytest.FixtureRequest) -> Iterator[None]:
    """Fail an SDK test module that leaves threads or sockets behind once all its tests are done.

    A disconnected ``XArmAPI``'s threads take about 2 s to notice their closed sockets; checking at
    the end of the module lets them end while the next tests run instead of after each test."""
    if not _module_name(request).startswith(_SDK):
        yield
        return
    threads = set(threading.enumerate())
    sockets = _open_sockets()
    yield
    _assert_no_leaks(threads, sockets, str(request.module.__name__))


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
    through :func:`xarm_emu.testing.sdk_pointed_at`; disconnected (in the background) and the SDK's
    configuration restored at teardown. For SDK test modules only: their leak check waits at the
    module's end for the disconnects to finish."""
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
            # The SDK's disconnect closes its sockets, then joins its threads, which notice the
            # close about a second later; that wait runs in the background while the next test
            # does, and the end-of-module leak check makes sure it finished.
            threading.Thread(target=_disconnect, args=(arm,), name="sdk-disconnect", daemon=True).start()


def _disconnect(arm: Any) -> None:
    with contextlib.suppress(Exception):
        arm.disconnect()


SharedArm = Callable[..., tuple[Any, ServerThread]]


@pytest.fixture(scope="module")
def shared_sdk_arm(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SharedArm]:
    """``shared_sdk_arm(report_type='rich', **config)``: one server (``ServerConfig`` fields as
    keywords) and one official ``XArmAPI`` connected to it, built on first use and shared by the
    tests of a module that ask for the same arguments; disconnected and stopped at the module's end.

    Tests that share an arm must leave the box as the start sequence does, or reset it first."""
    from xarm.wrapper import XArmAPI

    from xarm_emu.testing import sdk_pointed_at

    shared: dict[tuple[Any, ...], tuple[Any, ServerThread]] = {}
    with contextlib.ExitStack() as stack:

        def factory(report_type: str = "rich", **config: Any) -> tuple[Any, ServerThread]:
            key = (report_type, *sorted(config.items()))
            if key not in shared:
                emulator = Emulator(6, config_dir=tmp_path_factory.mktemp("shared-config"))
                cfg = ServerConfig(**{"host": "127.0.0.1", "port": 0, "normal_port": 0, "rich_port": 0,
                                      "develop_port": 0, **config})
                st = ServerThread(emulator, cfg).start()
                stack.callback(st.stop)
                stack.enter_context(sdk_pointed_at(st))
                arm = XArmAPI("127.0.0.1", report_type=report_type, forbid_uds=True)
                stack.callback(arm.disconnect)
                shared[key] = (arm, st)
            return shared[key]

        yield factory
