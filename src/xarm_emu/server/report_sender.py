"""One report sender per process: a thread that writes every report frame (manual 2.1.6) of every
server in the process on an absolute schedule, so no event loop's work delays a frame.

Each report stream (:class:`SendStream`) is due at ``k * interval`` (perf_counter seconds;
absolute deadlines on one grid per rate, nothing accumulates; the streams of one rate share their
instants, so one wake-up and one call into each event loop serve all of them). A little before each
deadline (:data:`LEAD`) the sender
asks the stream's event loop to publish its frame (the loop catches the controller up and encodes
it: the frame is the state no older than one control period at its deadline), unless the last
frame still stands for it (the box has not changed and its next timer is later:
:meth:`SendStream.stands_for`, so an arm at rest costs its loop nothing per frame); at the deadline the
sender writes the freshest published frame to every reader itself, with non-blocking ``send`` calls
on its own duplicates of the sockets, without waiting on the loop. A frame the loop could not
publish in time (it was blocked) goes out on time with the previous state and is counted
(``frames_stale``): timing first, as a real-time controller's report. A loop has at most one such
request queued (:class:`LoopAsk`): one that has fallen behind publishes once for the coming
deadline, and its queue never fills with requests for deadlines already past.

The sends hold the interpreter lock for the whole burst (``send(2)`` through ``ctypes.PyDLL``, a
few microseconds per reader) so the sender does not hand the lock back to the loop between
readers; a shorter switch interval and frozen start-up objects (``gc.freeze``) bound how long the
sender waits for the lock when it wakes.

A reader whose socket is full skips whole frames (counted per reader and frame in
``frames_skipped``); a frame partly written is finished before the next one, so every reader reads
whole frames.
"""

from __future__ import annotations

import asyncio
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

#: Seconds before a frame's deadline at which its loop is asked to publish it (at most half the
#: stream's interval): long enough for a busy loop to get to it, short enough (under one control
#: period, 4 ms) that the frame shows the state at most one period older than its deadline.
LEAD = 0.003
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


class LoopAsk:
    """The publish requests waiting on one event loop: at most one call is queued on the loop at a
    time. A loop that has fallen behind (saturated, or blocked) finds every stream asked for since
    its last turn in one call and publishes each for its current deadline, so requests never pile up
    in its queue: the frames it publishes are the freshest it can, and anything else it has to do
    (a stop, a closing connection) waits at most one such call."""

    __slots__ = ("streams", "queued", "lock")

    def __init__(self) -> None:
        self.streams: dict[SendStream, None] = {}
        self.queued = False
        self.lock = threading.Lock()

    def ask(self, streams: list[SendStream]) -> bool:
        """Add ``streams`` (sender thread); ``True`` if the loop must be called (none is queued)."""
        with self.lock:
            for stream in streams:
                self.streams[stream] = None
            if self.queued:
                return False
            self.queued = True
            return True

    def run(self) -> None:
        """In the loop: publish every stream asked for, each for its current deadline."""
        with self.lock:
            streams = tuple(self.streams)
            self.streams.clear()
            self.queued = False
        for stream in streams:
            stream.publish(stream.deadline)


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


class SendStream:
    """One report stream of one server (a port's readers at one rate), as the sender sees it.

    ``prepare`` runs in the stream's event loop before each deadline and returns the frame to send
    (``None``: none, e.g. reports paused). The counters are the sender's to write.

    ``revision`` and ``horizon``, when given, let a frame stand for later deadlines without the loop:
    ``revision()`` reads the box's revision (``Emulator.revision``; safe from the sender thread, it
    runs nothing) and ``horizon()``, in the loop right after ``prepare``, says until when
    (perf_counter) the frame stays what a fresh one would be while that revision holds (an arm at
    rest: until its next timer, thermal step or scheduled action).
    """

    def __init__(self, kind: str, interval: float, prepare: Callable[[], bytes | None],
                 revision: Callable[[], int] | None = None,
                 horizon: Callable[[], float] | None = None) -> None:
        self.kind = kind
        self.interval = interval
        self.prepare = prepare
        self.revision = revision
        self.horizon = horizon
        #: The published frame stays valid for deadlines before this time at :attr:`valid_revision`.
        self.valid_until = -math.inf
        self.valid_revision = -1
        self.readers: tuple[Reader, ...] = ()
        self.loop: asyncio.AbstractEventLoop | None = None
        self.frame: bytes | None = None
        #: The deadline the published frame was prepared for.
        self.frame_deadline = -1.0
        self.deadline = 0.0
        self.scheduled = False
        self.frames_sent = 0
        self.frames_skipped = 0
        self.frames_missed = 0
        self.frames_stale = 0
        #: Held by the sender from taking the frame to its last write of it: whoever replaces the
        #: frame and then takes this lock knows no write of the old one is still to come.
        self.sending = threading.Lock()
        #: Set to a list to record each frame's send time (perf_counter; benchmarks).
        self.frame_times: list[float] | None = None
        #: Set to a list to record each frame's lateness after its deadline (seconds; benchmarks).
        self.lateness: list[float] | None = None

    def publish(self, deadline: float) -> None:
        """In the loop: encode the frame for ``deadline`` (and say how long it stays valid)."""
        if not self.readers:
            return
        self.frame = frame = self.prepare()
        if frame is not None and self.horizon is not None and self.revision is not None:
            self.valid_revision = self.revision()
            self.valid_until = self.horizon()
        else:
            self.valid_until = -math.inf
        self.frame_deadline = deadline

    def invalidate(self) -> None:
        """The published frame stands for no later deadline: the loop is asked again (reports
        paused or closing: things the box's revision does not show)."""
        self.valid_until = -math.inf

    def stands_for(self, deadline: float) -> bool:
        """Sender thread: whether the published frame is what the loop would publish for
        ``deadline`` (the box unchanged, its horizon not reached); if so it is taken as published
        for it. Under :attr:`sending`, so that a refresh sees either the old deadline or this one."""
        if deadline >= self.valid_until or self.frame is None or self.revision is None:
            return False
        with self.sending:
            if self.revision() != self.valid_revision or deadline >= self.valid_until:
                return False
            self.frame_deadline = deadline
            return True


class ReportSender:
    """The process's report sender thread (:func:`acquire` / :func:`release`)."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._heap: list[tuple[float, int, SendStream, bool]] = []
        self._seq = 0
        self._stop = False
        self._retired: deque[Reader] = deque()
        self._asks: dict[asyncio.AbstractEventLoop, LoopAsk] = {}
        #: The sender thread's real-time priority (0: normal scheduling), :meth:`set_priority`.
        self.priority = 0
        self._switch = sys.getswitchinterval()
        sys.setswitchinterval(min(self._switch, SWITCH_INTERVAL))
        global _frozen
        if not _frozen:  # once: start-up objects out of every collection, short ones while serving
            gc.freeze()
            _frozen = True
        self._thread = threading.Thread(target=self._run, name="xarm-emu-reports", daemon=True)
        self._thread.start()

    # -- called from event loops ---------------------------------------------------------------
    def add(self, stream: SendStream, reader: Reader, loop: asyncio.AbstractEventLoop) -> None:
        """A new reader of ``stream``; a stream that had none starts its schedule now."""
        with self._cond:
            for gone in [lp for lp in self._asks if lp.is_closed()]:  # servers stopped since
                del self._asks[gone]
            stream.loop = loop
            stream.readers = (*stream.readers, reader)
            if not stream.scheduled:
                stream.scheduled = True
                stream.deadline = on_grid(time.perf_counter(), stream.interval)
                self._push(stream.deadline - min(LEAD, stream.interval / 2), stream, True)

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

    # -- the thread ----------------------------------------------------------------------------
    def _push(self, when: float, stream: SendStream, prep: bool) -> None:
        self._seq += 1
        heapq.heappush(self._heap, (when, self._seq, stream, prep))
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
                if not self._heap:
                    cond.wait()
                    continue
                when = self._heap[0][0]
                delay = when - time.perf_counter()
                if delay > 0:
                    # One timed wait to the deadline (a new, earlier event wakes it): each wake-up
                    # costs a wait for the interpreter lock, so there is one per event.
                    cond.wait(delay)
                    continue
                due = [heapq.heappop(self._heap)]  # every event of this instant: one grid, one wake-up
                while self._heap and self._heap[0][0] == when:
                    due.append(heapq.heappop(self._heap))
            self._request([d[2] for d in due if d[3]])
            for d in due:
                if not d[3]:
                    self._send(d[2])

    def _request(self, streams: list[SendStream]) -> None:
        """Ask the streams' loops to publish their next frames (one call per loop), then wait for
        their deadlines."""
        if not streams:
            return
        by_loop: dict[asyncio.AbstractEventLoop, list[SendStream]] = {}
        for stream in streams:
            if stream.loop is not None and not stream.stands_for(stream.deadline):
                by_loop.setdefault(stream.loop, []).append(stream)
        for loop, group in by_loop.items():
            with self._cond:
                pending = self._asks.get(loop)
                if pending is None:
                    pending = self._asks[loop] = LoopAsk()
            if not pending.ask(group):
                continue  # the loop has not got to the last call yet: it publishes these with it
            try:
                loop.call_soon_threadsafe(pending.run)
            except RuntimeError:  # the loop closed meanwhile
                with self._cond:
                    self._asks.pop(loop, None)
        with self._cond:
            for stream in streams:
                self._push(stream.deadline, stream, False)

    def _send(self, stream: SendStream) -> None:
        deadline = stream.deadline
        readers = stream.readers
        with stream.sending:  # from taking the frame to its last write (ReportStreams.refresh)
            frame = stream.frame
            skipped = 0
            if readers and frame is not None:
                for r in readers:
                    if not r.dead and not r.offer(frame):
                        skipped += 1
        if readers and frame is not None:
            now = time.perf_counter()
            if stream.frame_deadline != deadline:
                stream.frames_stale += 1
            stream.frames_skipped += skipped
            stream.frames_sent += 1
            if stream.frame_times is not None:
                stream.frame_times.append(now)
            if stream.lateness is not None:
                stream.lateness.append(now - deadline)
        with self._cond:
            if not stream.readers:  # nobody left: no wake-ups until the next reader
                stream.scheduled = False
                stream.frame = None
                return
            nxt, missed = next_deadline(deadline, stream.interval, time.perf_counter())
            stream.frames_missed += missed
            stream.deadline = round(nxt / stream.interval) * stream.interval  # exactly on the grid
            self._push(nxt - min(LEAD, stream.interval / 2), stream, True)

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
        sys.setswitchinterval(self._switch)


_lock = threading.Lock()
_frozen = False
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
