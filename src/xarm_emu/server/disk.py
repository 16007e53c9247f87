"""Disk work off the event loop: saved configurations (registers 39/40, manual 2.1.3) and the
command trace are written by one worker thread fed through a bounded queue, so a slow, full or
read-only disk never holds the command port or the report streams (2.1.6), and closing the server
takes a bounded time whatever the disk does.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import errno
import logging
import queue
import threading
from collections.abc import Callable
from typing import Any

from ..controller.core.config import describe_os_error

__all__ = ["DiskBusy", "DiskWorker", "describe_os_error"]

log = logging.getLogger("xarm_emu.server")

#: Jobs that may wait for the disk; beyond it :meth:`DiskWorker.submit` refuses (:class:`DiskBusy`).
QUEUE_SIZE = 64
#: Longest wait for the disk when the server closes (seconds); then the worker is left behind (it
#: is a daemon thread and cannot keep the process alive).
CLOSE_TIMEOUT = 0.8

class DiskBusy(OSError):
    """The disk worker's queue is full (the disk is much slower than the writes asked of it)."""


class DiskWorker:
    """One daemon thread running disk jobs in order, fed by a bounded queue."""

    def __init__(self, size: int = QUEUE_SIZE) -> None:
        self._queue: queue.Queue[tuple[Callable[[], Any], concurrent.futures.Future[Any]] | None] = \
            queue.Queue(maxsize=size)
        self._thread = threading.Thread(target=self._run, name="xarm-emu-disk", daemon=True)
        self._thread.start()
        self._closed = False

    def submit(self, job: Callable[[], Any]) -> concurrent.futures.Future[Any]:
        """Queue ``job``; its future holds its result or its exception. :class:`DiskBusy` when the
        queue is full or the worker closed."""
        fut: concurrent.futures.Future[Any] = concurrent.futures.Future()
        if self._closed:
            raise DiskBusy(errno.EBUSY, "the disk worker has stopped")
        try:
            self._queue.put_nowait((job, fut))
        except queue.Full:
            raise DiskBusy(errno.EBUSY, "too many disk writes waiting") from None
        return fut

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            job, fut = item
            if not fut.set_running_or_notify_cancel():
                continue
            try:
                fut.set_result(job())
            except BaseException as exc:  # noqa: BLE001 - handed to whoever waits on the future
                fut.set_exception(exc)

    def close(self, timeout: float = CLOSE_TIMEOUT) -> bool:
        """Run what is queued, then stop; wait at most ``timeout`` s. ``True`` if the worker ended."""
        if not self._closed:
            self._closed = True
            with contextlib.suppress(queue.Full):
                self._queue.put(None, timeout=timeout)
        self._thread.join(timeout)
        alive = self._thread.is_alive()
        if alive:
            log.warning("disk writes still pending after %.1f s at shutdown; leaving them", timeout)
        return not alive
