"""The emulator server on a background thread with its own event loop (tests, embedding)."""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Callable, Iterable

from ..controller.emulator import Emulator
from .core import EmulatorServer, ServerConfig
from .faults import schedule_file


def new_event_loop(use_uvloop: bool = False) -> asyncio.AbstractEventLoop:
    """A fresh event loop; uvloop's when asked for and installed (Linux, macOS)."""
    if use_uvloop:
        try:
            import uvloop  # type: ignore[import-not-found]

            return uvloop.new_event_loop()
        except ImportError:
            pass
    return asyncio.new_event_loop()


class ServerThread:
    """The emulator server on a background thread with its own event loop (tests, embedding).

    It composes the server: the fault schedule of ``config.faults`` is checked and scheduled here
    (:class:`~xarm_emu.server.faults.FaultScheduleError` before anything starts), and each of
    ``compose`` is called with the server before it starts (e.g. ``viewer.app.attach_viewer``).
    """

    def __init__(self, emulator: Emulator, config: ServerConfig | None = None, *,
                 use_uvloop: bool = False,
                 compose: Iterable[Callable[[EmulatorServer], None]] = ()) -> None:
        self.server = EmulatorServer(emulator, config)
        schedule_file(self.server, self.server.config.faults)
        for fn in compose:
            fn(self.server)
        self.loop = new_event_loop(use_uvloop)
        self._thread = threading.Thread(target=self._run, name="xarm-emu-server", daemon=True)
        self._ready = threading.Event()
        self._error: BaseException | None = None

    @property
    def emulator(self) -> Emulator:
        return self.server.emulator

    @property
    def ports(self) -> dict[str, int]:
        return self.server.ports

    def _run(self) -> None:
        asyncio.set_event_loop(self.loop)
        try:
            self.loop.run_until_complete(self.server.start())
        except BaseException as exc:  # noqa: BLE001 - reported to the starting thread
            self._error = exc
            with contextlib.suppress(Exception):
                self.loop.run_until_complete(self.server.close())
            self.loop.close()
            self._ready.set()
            return
        self._ready.set()
        self.loop.run_forever()

    def start(self) -> ServerThread:
        self._thread.start()
        self._ready.wait(10)
        if self._error is not None:
            self._thread.join(10)
            raise self._error
        return self

    def call(self, fn: Callable[[], object]) -> object:
        """Run ``fn`` in the server's loop thread and return its result."""
        async def wrapper() -> object:
            with self.server.lock:  # as a command: between report frames, never during one
                self.server.catch_up()
                try:
                    return fn()
                finally:
                    self.server.emulator.touch()

        return asyncio.run_coroutine_threadsafe(wrapper(), self.loop).result(10)

    def stop(self) -> None:
        if not self._thread.is_alive():
            return
        fut = asyncio.run_coroutine_threadsafe(self.server.close(), self.loop)
        with contextlib.suppress(Exception):
            fut.result(10)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self._thread.join(10)
        self.loop.close()

    def __enter__(self) -> ServerThread:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
