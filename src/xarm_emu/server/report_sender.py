"""One report sender per process: a thread that makes and writes every report frame (manual 2.1.6)
of every server in the process on an absolute schedule, so no event loop's work delays a frame.

Each report stream (:class:`SendStream`) is due at ``k * interval`` (perf_counter seconds;
absolute deadlines on one grid per rate, nothing accumulates; the streams of one rate share their
instants, so one wake-up serves all of them). At each deadline the sender itself, holding the arm's
lock (the one every command, admin request and control-loop catch-up of that arm also takes),
advances the controller to the control period of the deadline, encodes the frame from that state
and writes it to every reader with non-blocking ``send`` calls on its own duplicates of the
sockets. So every frame is the box's state at its own deadline, whatever the event loop is doing,
and a command either lands before a frame (the frame shows it) or after its write (its reply comes
after the frame): no frame sent after a reply shows the state from before its command.

The sends use ``send(2)`` through ``ctypes.PyDLL``, which keeps the interpreter lock for the whole
burst (a few microseconds per reader), so the sender is not preempted between readers. How long
the sender waits for the interpreter lock when it wakes is the process's switch interval: the
``serve`` command shortens it (:func:`tune_process`); a library user's process keeps its own.

The sender also wakes each server's control loop when its nap is over (:meth:`ReportSender.wake_at`),
so an event loop keeps no timer of its own while it serves requests (see ``EmulatorServer._nap``).

A reader whose socket is full skips whole frames (counted per reader and frame in
``frames_skipped``); a frame partly written is finished before the next one, so every reader reads
whole frames.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import gc
import heapq
import math
import os
import socket
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

#: A frame written more than this after its deadline (one control period, seconds) is counted late
#: (``frames_late``): the process was too busy to make it in time.
LATE_AFTER = 0.004
#: A stream this many intervals behind its schedule or less sends the due frames at once; further
#: behind (the process was suspended), it re-anchors and counts the frames it missed.
LATE_FRAMES = 10
#: The sender thread's real-time (``SCHED_FIFO``) priority unless told otherwise, as a control
#: box's report comes from a real-time task: taken where the system allows it (root, or the
#: ``CAP_SYS_NICE`` capability, or an ``RLIMIT_RTPRIO`` of at least this), else the sender runs at
#: normal priority without complaint. The thread sleeps between frames and sends each in a few
#: microseconds per reader, and the kernel's real-time throttling bounds it anyway.
DEFAULT_PRIORITY = 10
#: The interpreter's switch interval while a sender runs (seconds): how long a thread that holds
#: the lock keeps it before the woken sender gets it (the default is 5 ms).
SWITCH_INTERVAL = 0.0002

_FLAGS = getattr(socket, "MSG_DONTWAIT", 0) | getattr(socket, "MSG_NOSIGNAL", 0)
_AGAIN = frozenset({errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR})


def _libc_send() -> Callable[[int, bytes, int, int], int] | None:
    """``send(2)`` called with the interpreter lock held (``ctypes.PyDLL``), or ``None`` off POSIX."""
    if os.name != "posix" or not _FLAGS:
        return None
    try:
        libc = ctypes.PyDLL(None, use_errno=True)
        fn = libc.send
    except (OSError, AttributeError):
        return None
    fn.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_size_t, ctypes.c_int)
    fn.restype = ctypes.c_ssize_t
    return fn  # type: ignore[no-any-return]


_SEND = _libc_send()


def next_deadline(deadline: float, interval: float, now: float) -> tuple[float, int]:
    """The deadline after ``deadline`` and the frames missed on the way: one interval on, on the
    absolute schedule (a late frame does not move the ones after it), unless that is more than
    :data:`LATE_FRAMES` intervals behind ``now``: then the first deadline of the schedule after
    ``now``, the ones skipped counted as missed."""
    nxt = deadline + interval
    if nxt >= now - LATE_FRAMES * interval:
        return nxt, 0
    missed = math.ceil((now - nxt) / interval)
    return nxt + missed * interval, missed


def on_grid(now: float, interval: float) -> float:
    """The first deadline after ``now`` on the process-wide grid of ``interval`` (multiples of it
    on the ``perf_counter`` clock): streams of one rate share their instants, and one wake-up of
    the sender serves them all."""
    return (math.floor(now / interval) + 1) * interval


class Reader:
    """One report connection as the sender writes it: its own duplicate of the socket, and the rest
    of a frame the kernel did not take."""

    __slots__ = ("sock", "fd", "rest", "dead")

    def __init__(self, sock: Any) -> None:
        # A duplicate (of asyncio's or uvloop's socket): the loop closing its own cannot hand this
        # descriptor number to another file while the sender writes to it.
        self.sock = socket.socket(fileno=os.dup(sock.fileno()))
        self.sock.setblocking(False)
        self.fd = self.sock.fileno()
        self.rest = b""
        self.dead = False

    def _send(self, data: bytes) -> int:
        """Bytes the kernel took (0 when the socket is full); marks a broken connection dead."""
        if _SEND is not None:
            n = _SEND(self.fd, data, len(data), _FLAGS)
            if n >= 0:
                return int(n)
            err = ctypes.get_errno()
            if err in _AGAIN:
                return 0
            self.dead = True
            return 0
        try:
            return self.sock.send(data)
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError:
            self.dead = True
            return 0

    def offer(self, frame: bytes) -> bool:
        """Write ``frame`` unless the reader is still behind; returns whether it was taken."""
        if self.rest:
            n = self._send(self.rest)
            self.rest = self.rest[n:]
            if self.rest:
                return False
        n = self._send(frame)
        if n == 0:
            return False
        if n < len(frame):
            self.rest = frame[n:]
        return True


class Wake:
    """A call the sender makes at its time (:meth:`ReportSender.wake_at`), unless cancelled first."""

    __slots__ = ("fn", "cancelled")

    def __init__(self, fn: Callable[[], object]) -> None:
        self.fn = fn
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True


class SendStream:
    """One report stream of one server (a port's readers at one rate), as the sender sees it.

    At each deadline the sender calls ``frame(deadline)`` holding ``lock`` (the arm's lock) and
    writes what it returns to every reader before letting go of the lock (``None``: no frame, e.g.
    reports paused; empty: the deadline's state is gone, the sender was too late, or the
    controller cannot reach it in one catch-up, counted in ``frames_missed``). The counters are the
    sender's to write."""

    def __init__(self, kind: str, interval: float, frame: Callable[[float], bytes | None],
                 lock: threading.RLock | None = None) -> None:
        self.kind = kind
        self.interval = interval
        self.frame = frame
        self.lock = lock if lock is not None else threading.RLock()
        self.readers: tuple[Reader, ...] = ()
        self.deadline = 0.0
        self.scheduled = False
        self.frames_sent = 0
        self.frames_skipped = 0
        self.frames_missed = 0
        self.frames_late = 0
        #: Set to a list to record each frame's send time (perf_counter; benchmarks, tests).
        self.frame_times: list[float] | None = None
        #: Set to a list to record each frame's lateness after its deadline (seconds; benchmarks).
        self.lateness: list[float] | None = None


def tune_process() -> None:
    """Interpreter-wide settings for a process that serves arms and nothing else (the ``serve``
    command calls this; a library user's process is never changed): a switch interval of
    :data:`SWITCH_INTERVAL` bounds how long the woken sender waits for the interpreter lock (the
    default 5 ms would be a 5 ms late frame), and the start-up objects are frozen out of the
    garbage collector (``gc.freeze``), so a collection while serving walks only what serving made."""
    sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL))
    gc.freeze()


class ReportSender:
    """The process's report sender thread (:func:`acquire` / :func:`release`)."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._heap: list[tuple[float, int, SendStream | Wake]] = []
        self._seq = 0
        self._stop = False
        self._retired: deque[Reader] = deque()
        #: The sender thread's real-time priority (0: normal scheduling), :meth:`set_priority`.
        self.priority = 0
        self._thread = threading.Thread(target=self._run, name="xarm-emu-reports", daemon=True)
        self._thread.start()

    # -- called from event loops ---------------------------------------------------------------
    def add(self, stream: SendStream, reader: Reader) -> None:
        """A new reader of ``stream``; a stream that had none starts its schedule now."""
        with self._cond:
            stream.readers = (*stream.readers, reader)
            if not stream.scheduled:
                stream.scheduled = True
                stream.deadline = on_grid(time.perf_counter(), stream.interval)
                self._push(stream.deadline, stream)

    def remove(self, stream: SendStream, reader: Reader) -> None:
        """``reader`` is gone: the sender stops writing to it and closes its socket."""
        with self._cond:
            stream.readers = tuple(r for r in stream.readers if r is not reader)
            if self._stop:
                with contextlib.suppress(OSError):
                    reader.sock.close()
                return
            self._retired.append(reader)
            self._cond.notify()

    def wake_at(self, when: float, fn: Callable[[], object]) -> Wake:
        """Call ``fn`` on the sender thread at ``when`` (perf_counter seconds) unless the returned
        :class:`Wake` is cancelled first. ``fn`` must be quick and must not raise: it hands the
        wake-up to an event loop (``loop.call_soon_threadsafe``)."""
        wake = Wake(fn)
        with self._cond:
            self._push(when, wake)
        return wake

    # -- the thread ----------------------------------------------------------------------------
    def _push(self, when: float, item: SendStream | Wake) -> None:
        self._seq += 1
        heapq.heappush(self._heap, (when, self._seq, item))
        self._cond.notify()

    def _run(self) -> None:
        cond = self._cond
        while True:
            with cond:
                while self._retired:
                    with contextlib.suppress(OSError):
                        self._retired.popleft().sock.close()
                if self._stop:
                    return
                heap = self._heap
                while heap and isinstance(heap[0][2], Wake) and heap[0][2].cancelled:
                    heapq.heappop(heap)  # a nap ended early: no wake-up for it
                if not heap:
                    cond.wait()
                    continue
                when = heap[0][0]
                delay = when - time.perf_counter()
                if delay > 0:
                    # One timed wait to the deadline (a new, earlier event wakes it): each wake-up
                    # costs a wait for the interpreter lock, so there is one per instant.
                    cond.wait(delay)
                    continue
                due = [heapq.heappop(heap)[2]]  # every stream of this instant: one wake-up
                while heap and heap[0][0] == when:
                    due.append(heapq.heappop(heap)[2])
            for item in due:
                if isinstance(item, Wake):
                    if not item.cancelled:
                        item.fn()
                else:
                    self._send(item)

    def _send(self, stream: SendStream) -> None:
        """Make ``stream``'s frame for its deadline and write it, under the arm's lock."""
        deadline = stream.deadline
        readers = stream.readers
        frame = None
        skipped = 0
        if readers:
            with stream.lock:
                frame = stream.frame(deadline)
                if frame:
                    for r in readers:
                        if not r.dead and not r.offer(frame):
                            skipped += 1
        if frame == b"":
            stream.frames_missed += 1
        elif frame is not None:
            now = time.perf_counter()
            stream.frames_skipped += skipped
            stream.frames_sent += 1
            if now - deadline > LATE_AFTER:
                stream.frames_late += 1
            if stream.frame_times is not None:
                stream.frame_times.append(now)
            if stream.lateness is not None:
                stream.lateness.append(now - deadline)
        with self._cond:
            if not stream.readers:  # nobody left: no wake-ups until the next reader
                stream.scheduled = False
                return
            nxt, missed = next_deadline(deadline, stream.interval, time.perf_counter())
            stream.frames_missed += missed
            stream.deadline = round(nxt / stream.interval) * stream.interval  # exactly on the grid
            self._push(stream.deadline, stream)

    def set_priority(self, priority: int | None) -> str | None:
        """Run the sender thread at real-time priority ``priority`` (``SCHED_FIFO``, Linux; it only
        sleeps and writes, so it cannot hog a CPU); returns why not when the system refuses.

        ``None`` asks for :data:`DEFAULT_PRIORITY` where the system allows it and is never refused
        (the thread stays at normal priority); 0 asks for nothing."""
        if priority is None:
            self.set_priority(DEFAULT_PRIORITY)
            return None
        if priority <= 0 or priority <= self.priority:
            return None
        tid = self._thread.native_id
        try:
            os.sched_setscheduler(tid or 0, os.SCHED_FIFO, os.sched_param(priority))  # type: ignore[attr-defined]
        except (OSError, AttributeError) as exc:
            return f"cannot give the report sender real-time priority {priority}: {exc}"
        self.priority = priority
        return None

    def close(self) -> None:
        with self._cond:
            self._stop = True
            self._cond.notify()
        self._thread.join(2)
        while self._retired:
            with contextlib.suppress(OSError):
                self._retired.popleft().sock.close()


_lock = threading.Lock()
_shared: ReportSender | None = None
_users = 0


def acquire() -> ReportSender:
    """The process's sender, started by its first user."""
    global _shared, _users
    with _lock:
        if _shared is None:
            _shared = ReportSender()
        _users += 1
        return _shared


def release() -> None:
    """One user fewer; the last one stops the sender."""
    global _shared, _users
    with _lock:
        _users -= 1
        if _users > 0 or _shared is None:
            return
        sender, _shared = _shared, None
    sender.close()
