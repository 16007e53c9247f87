"""``xarm-emu compare session.xrec``: a recorded session replayed into the emulator, and how far apart.

The recording (``xarm-emu proxy``, :mod:`xarm_emu.server.xrec`) says which arm and firmware the box is
(its register 1 reply). A fresh emulator of that arm and firmware (with a calibration when given) runs
on the stepped clock; every recorded request is answered by it, in order, at the place the box
answered it, and its state is sampled at the controller time of every recorded real-time report
frame (port 30000, whose timestamp is the box's clock; manual 2.1.6 and firmware 2.x). A command's
place is the first real-time frame that shows it and its control period
(:mod:`xarm_emu.server.placement`): of the places its round trip leaves open, the one answered as
recorded after which the replayed joints, then torques, follow the recorded frames
(:meth:`_Replay.position`). A pure read is tried at every
period its round trip leaves open. Report rates are measured per connection.

Reported per command and in total: replies that differ (state byte or parameters); move durations
(from the command to the first report at rest after it moved); the path deviation (the distance of each
recorded TCP position from the replayed path, mm, and of the joints, degrees); joint torque and current
differences at every real-time frame (RMS and maximum; the replayed poses, torques and currents are
computed in one batch after the replay, :meth:`_Replay.derive`); the error and warning codes of every
normal and rich report frame and of every register 15 reply against the emulator's at the same
controller time (:func:`_codes`); report rates. The TCP offset, load and settings come from the
recorded commands themselves, as they are replayed. A recording without the real-time report is
compared on what the command port shows (:data:`COMMAND_PORT_ONLY` says what that leaves out).
"""

from __future__ import annotations

import bisect
import copy
import math
import tempfile
from array import array
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..controller.controller import joint_torques_many
from ..controller.core.interface import PERIOD
from ..model import dynamics as dyn
from ..model import kinematics as kin
from ..model.calibration import Calibration
from ..model.robots import ROBOT_MODELS, RobotModel, with_calibration
from ..protocol import registers as regs
from ..protocol import reports
from ..protocol.firmware import DEFAULT_PROFILE, FirmwareProfile
from ..server import placement, xrec
from ..server.command_port import PURE_READS
from ..tomlfile import check_keys, load_toml

#: Documented default tolerances (``--tolerances FILE`` overrides any of them, TOML keys as here).
DEFAULT_TOLERANCES: dict[str, float] = {
    "reply_differences": 0,  # replies that may differ
    "duration_s": PERIOD + 1e-9,  # a move's duration, seconds (one control period)
    "path_mm": 0.01,  # TCP distance from the replayed path, mm
    "path_deg": 0.01,  # joint distance from the replayed path, degrees
    "torque_rms": 0.02,  # N.m, per joint over the session
    "torque_max": 0.05,  # N.m
    "current_rms": 0.01,  # A
    "current_max": 0.02,  # A
    "code_differences": 0,  # error or warning codes seen in one only, register 15 replies that differ
    "code_timing_s": 0.2 + 1e-9,  # when a code is first seen, recorded against replayed (one report period)
    "report_rate_rel": 0.2,  # relative difference of a report rate from the emulator's
}


#: get_err_warn_code (manual 2.1.3): its reply carries the error and the warning code.
ERR_WARN_REGISTER = 15

class CompareError(ValueError):
    """The recording cannot be compared; the message says why."""


@dataclass
class Samples:
    """Real-time report frames as columns, one row per frame (recorded, or the replayed state at each
    recorded frame's controller time): controller time (s), state, joints (rad), TCP position (mm),
    joint torques (N m), currents (A) and speeds (rad/s). Columns, not an object per frame: a
    10-minute recording holds 150 000 frames."""

    t: np.ndarray
    state: np.ndarray
    joints: np.ndarray
    pos: np.ndarray
    torques: np.ndarray
    currents: np.ndarray
    speeds: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    @classmethod
    def empty(cls, n: int, dof: int) -> Samples:
        """``n`` rows of ``dof`` joints, the derived columns (position, torques, currents) NaN."""
        return cls(np.zeros(n), np.zeros(n, dtype=np.int64), np.zeros((n, dof)), np.full((n, 3), np.nan),
                   np.full((n, dof), np.nan), np.full((n, dof), np.nan), np.zeros((n, dof)))

    def head(self, n: int) -> Samples:
        """The first ``n`` rows."""
        return Samples(*(getattr(self, f)[:n] for f in _SAMPLE_COLUMNS))


_SAMPLE_COLUMNS = ("t", "state", "joints", "pos", "torques", "currents", "speeds")


@dataclass
class CommandResult:
    index: int
    t: float
    register: int
    name: str | None
    reply_differs: bool = False
    recorded_reply: str = ""
    replayed_reply: str = ""
    duration: tuple[float, float] | None = None  # recorded, replayed (s)
    path_mm: float = 0.0
    path_deg: float = 0.0
    torque_rms: float = 0.0
    torque_max: float = 0.0
    current_rms: float = 0.0
    current_max: float = 0.0
    samples: tuple[int, int] = (0, 0)  # sample index range [start, end)
    #: A register 15 (get_err_warn_code) reply's codes: recorded error, warning, replayed error, warning.
    reply_codes: tuple[int, int, int, int] | None = None
    #: The controller times the recording leaves open for it (earliest, latest; inf: no frame after it).
    window: tuple[float, float] = (0.0, 0.0)
    #: How its period was chosen (:data:`PLACEMENTS`).
    placed_by: str = ""
    #: Whether the recording could not decide its period (:data:`PLACEMENTS`).
    undecided: bool = False
    #: Of its real-time frames, those inside an undecided command's window (left out of its measures).
    excluded_frames: int = 0
    #: The undecided command whose window holds its answer (its reply not counted as a difference).
    inside: int | None = None


@dataclass
class Comparison:
    """Everything ``compare`` measured (module docstring); ``failures`` against the tolerances."""

    model: str
    firmware: str
    commands: list[CommandResult] = field(default_factory=list)
    totals: dict[str, float] = field(default_factory=dict)
    per_joint: dict[str, list[float]] = field(default_factory=dict)
    codes: dict[str, list[Any]] = field(default_factory=dict)  # see _codes
    #: port -> recorded (of its connection farthest from the emulator's rate), emulator's
    rates: dict[str, list[float]] = field(default_factory=dict)
    #: every report connection's rate: conn, port, frames, rate (frames per second)
    rate_connections: list[dict[str, float]] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)
    recorded: Samples = field(default_factory=lambda: Samples.empty(0, 0), repr=False)
    replayed: Samples = field(default_factory=lambda: Samples.empty(0, 0), repr=False)
    replay_seconds: float = 0.0
    session: Session | None = field(default=None, repr=False)
    #: What this comparison could not measure and why (a recording without some report stream).
    notes: list[str] = field(default_factory=list)
    #: The tolerances it was measured against (DEFAULT_TOLERANCES and ``--tolerances``).
    tolerances: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {"model": self.model, "firmware": self.firmware, "notes": self.notes, "totals": self.totals,
                "tolerances": self.tolerances, "per_joint": self.per_joint, "codes": self.codes,
                "rates": self.rates, "rate_connections": self.rate_connections,
                "failures": self.failures, "commands": [_command_json(c) for c in self.commands],
                "undecided": [{"request": c.index, "name": c.name, "from": _finite(c.window[0]),
                               "to": _finite(c.window[1]), "why": c.placed_by}
                              for c in self.commands if c.undecided]}


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _command_json(c: CommandResult) -> dict[str, Any]:
    """A command's fields for ``--json`` (its attributes, shallow: asdict's deep copies cost 0.25 ms
    each), an open end of its window as ``null``."""
    out = dict(vars(c))
    out["window"] = [_finite(x) for x in c.window]
    return out


def load_tolerances(path: Path | None) -> dict[str, float]:
    """The default tolerances, overridden by a TOML file's keys."""
    tol = dict(DEFAULT_TOLERANCES)
    if path is None:
        return tol

    def parse(data: dict[str, Any]) -> dict[str, float]:
        check_keys(data, tol, error=CompareError)
        for k, v in data.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v >= 0:
                raise CompareError(f"{k} must be a number >= 0")
            tol[k] = float(v)
        return tol

    return load_toml(path, "tolerances file", parse, CompareError)


def model_of(version: str) -> RobotModel:
    """The arm of a register 1 version string (``axis,type,robot SN,...``)."""
    try:
        axis, rtype = (int(x) for x in version.split(",")[:2])
    except ValueError:
        raise CompareError(f"the box's version {version!r} does not name its arm") from None
    for m in ROBOT_MODELS.values():
        if m.axis == axis and m.robot_type == rtype:
            return m
    raise CompareError(f"no emulated arm has axis {axis} and type {rtype}")


@dataclass(frozen=True)
class StatusFrame:
    """What a normal or rich report frame (ports 30001, 30002; manual 2.1.6) showed: the error and
    warning codes (bytes 89, 90) and, in a rich frame, the joint temperatures (bytes 246-252)."""

    t: float  # proxy time
    port: int
    error: int
    warning: int
    temperatures: tuple[int, ...] | None
    sensitivity: int = 0  # collision sensitivity (register 37), byte 131


@dataclass
class Session:
    """A recording read for replay: the box, its requests and replies, its report frames."""

    version: str
    profile: FirmwareProfile
    requests: list[tuple[xrec.Req, xrec.Rep | None]]
    realtime: RealtimeFrames
    frames: dict[int, array[float]]  # report port -> proxy times
    status: list[StatusFrame] = field(default_factory=list)
    #: Report connection -> its port and the proxy times of its frames (rates are per connection).
    streams: dict[int, tuple[int, array[float]]] = field(default_factory=dict)

    def controller_times(self, proxy_times: np.ndarray | list[float]) -> np.ndarray:
        """Controller times of moments on the proxy's clock: read from the real-time frames around
        them (their timestamps are the box's clock), or, in a recording of the command port only, the
        proxy's clock moved so that the first request falls one control period after the start."""
        t = np.asarray(proxy_times, dtype=float)
        if not self.realtime:
            t0 = self.requests[0][0].t if self.requests else 0.0
            return t - t0 + PERIOD
        recv, ts = self.realtime.recv, self.realtime.ts
        out = np.interp(t, recv, ts)
        return np.where(t < recv[0], t - recv[0] + ts[0], np.where(t > recv[-1], t - recv[-1] + ts[-1], out))


@dataclass
class RealtimeFrames:
    """A recording's real-time report frames (port 30000), one row each in the order they came,
    without the frames sent again: the proxy's time, the controller time (the frame's timestamp),
    the state, and the joints (rad), speeds (rad/s), currents (A), torques (N m) and TCP position
    (mm) as float64 columns."""

    recv: np.ndarray
    ts: np.ndarray
    state: np.ndarray
    joints: np.ndarray
    speeds: np.ndarray
    currents: np.ndarray
    torques: np.ndarray
    pos: np.ndarray

    def __len__(self) -> int:
        return len(self.recv)


class _RealtimeReader:
    """Real-time frames read into columns as they come, :data:`CHUNK_FRAMES` at a time (the frames'
    bytes are not all held at once: a 10-minute recording has 150 000 of 804 bytes), at the offsets
    :data:`~xarm_emu.protocol.reports.REALTIME_COLUMNS` gives. A frame whose timestamp is not past
    every earlier one's is a frame sent again: it shows nothing new, and is left out."""

    def __init__(self) -> None:
        self.recv: list[float] = []
        self.raw = bytearray()
        self.chunks: list[tuple[np.ndarray, ...]] = []

    def add(self, t: float, frame: bytes) -> None:
        self.recv.append(t)
        self.raw += frame
        if len(self.recv) == CHUNK_FRAMES:
            self._flush()

    def _flush(self) -> None:
        if not self.recv:
            return
        rows = np.frombuffer(bytes(self.raw), dtype=_REALTIME_DTYPE)
        self.chunks.append((np.asarray(self.recv, dtype=float), rows["timestamp_us"].astype(np.int64),
                            rows["state_mode"] & 0x0F,
                            *(np.asarray(rows[name], dtype=float) for name in _REALTIME_FLOATS)))
        self.recv, self.raw = [], bytearray()

    def frames(self) -> RealtimeFrames:
        """Every frame read, those sent again left out."""
        self._flush()
        if not self.chunks:
            return RealtimeFrames(np.zeros(0), np.zeros(0), np.zeros(0, dtype=np.uint8),
                                  *(np.zeros((0, n)) for n in _REALTIME_WIDTHS))
        chunks: list[list[np.ndarray | None]] = [list(c) for c in self.chunks]
        self.chunks = []
        cols = []
        for k in range(len(chunks[0])):  # a column at a time, its chunks let go: never all twice
            cols.append(np.concatenate([c[k] for c in chunks if c[k] is not None]))
            for c in chunks:
                c[k] = None
        stamps = cols[1]
        seen = np.maximum.accumulate(stamps)
        keep = np.ones(len(stamps), dtype=bool)
        keep[1:] = stamps[1:] > seen[:-1]
        recv, ts, state, *floats = (c[keep] if not keep.all() else c for c in cols)
        return RealtimeFrames(recv, ts / 1e6, state, *floats)


#: Real-time frames read into columns at a time, and replayed frames derived at a time
#: (:meth:`_Replay.derive`: the dynamics' temporaries take about 1 KB a frame).
CHUNK_FRAMES = DERIVE_ROWS = 4096
#: The float columns of :class:`RealtimeFrames`, in its order, and their widths.
_REALTIME_FLOATS = ("joints", "joint_speeds", "joint_currents", "torques", "position")
_REALTIME_WIDTHS = tuple(reports.REALTIME_COLUMNS[name][2] for name in _REALTIME_FLOATS)


_NUMPY_TYPES = {">Q": ">u8", "B": "u1", "<f": "<f4"}
_REALTIME_DTYPE = np.dtype({
    "names": list(reports.REALTIME_COLUMNS),
    "formats": [np.dtype((_NUMPY_TYPES[fmt], (n,))) if n > 1 else np.dtype(_NUMPY_TYPES[fmt])
                for _, fmt, n in reports.REALTIME_COLUMNS.values()],
    "offsets": [off for off, _, _ in reports.REALTIME_COLUMNS.values()],
    "itemsize": reports.REALTIME_SIZE})


_STATUS_DECODERS = {reports.NORMAL_SIZE: reports.decode_normal, reports.RICH_SIZE: reports.decode_rich,
                    reports.RICH2_SIZE: reports.decode_rich2}


def read_session(path: Path) -> Session:
    """Pair every request with its reply (by connection and tid) and collect the report frames."""
    version, profile = "", DEFAULT_PROFILE
    requests: list[tuple[xrec.Req, xrec.Rep | None]] = []
    waiting: dict[tuple[int, int], int] = {}
    realtime_reader = _RealtimeReader()
    frames: dict[int, array[float]] = {}
    streams: dict[int, tuple[int, array[float]]] = {}
    status: list[StatusFrame] = []
    try:
        for rec in xrec.read(path):
            if isinstance(rec, xrec.Req) and rec.protocol != 1:
                if rec.values:  # of the decoded values only a move's blend radius is used (_blends)
                    rec.values = {"radius": rec.values["radius"]} if "radius" in rec.values else None
                waiting[(rec.conn, rec.tid)] = len(requests)
                requests.append((rec, None))
            elif isinstance(rec, xrec.Rep) and rec.register != 0xFF:
                i = waiting.pop((rec.conn, rec.tid), None)
                if i is not None:
                    requests[i] = (requests[i][0], rec)
                if rec.register == 1 and rec.values and not version:
                    version = str(rec.values.get("version", "")).strip("\0 ")
                    profile = xrec.firmware_of(version) or profile
                rec.values = None  # the reply's frame is compared, its decoded values are not kept
            elif isinstance(rec, xrec.Rpt):
                frames.setdefault(rec.port, array("d")).append(rec.t)
                streams.setdefault(rec.conn, (rec.port, array("d")))[1].append(rec.t)
                decode = _STATUS_DECODERS.get(len(rec.frame))
                if rec.port in (reports.NORMAL_PORT, reports.RICH_PORT) and decode is not None:
                    try:
                        st = decode(rec.frame)
                    except reports.ReportError:
                        continue
                    temps = tuple(st.temperatures) if len(rec.frame) != reports.NORMAL_SIZE else None
                    status.append(StatusFrame(rec.t, rec.port, st.error, st.warning, temps,
                                              st.collision_sensitivity))
                elif rec.port == reports.REALTIME_PORT and len(rec.frame) == reports.REALTIME_SIZE:
                    realtime_reader.add(rec.t, rec.frame)
    except xrec.RecordingError as exc:
        raise CompareError(str(exc)) from None
    if not version:
        raise CompareError(f"{path} has no register 1 reply: the box's arm and firmware are unknown "
                           "(the SDK asks for it on connecting; record from the program's start)")
    realtime = realtime_reader.frames()
    if not realtime and not requests:
        raise CompareError(f"{path} has neither requests nor real-time report frames: nothing to compare")
    return Session(version, profile, requests, realtime, frames, status, streams)


def _controller_times(session: Session) -> list[tuple[float, float, float]]:
    """The proxy clock's estimate of the controller time each request was answered at, and its
    bounds: the time of a read and of any command of a recording without real-time frames; for a
    command placed by the frames (:meth:`_Replay.position`), the estimate its candidates are tried
    nearest and the commands after one being placed are put at.

    Bounds: a frame the box sent before the request shows a time no later, the first frame it sent
    after the reply one no earlier. A queued command changes what the next frame shows, so the box
    prepares that frame again after answering it: its time is the command's. Those give the offset of
    the box's clock from the proxy's (the median); every request's time is then its arrival on the
    box's control-period grid, within its bounds. A pure read (its answer changes nothing) gets its
    earliest time: ``compare`` tries it again at each later period up to its upper bound, the time
    a round trip through a busy network or computer leaves open. Returns (time, upper bound, lower
    bound); a frame's timestamp may lead the box's clock by up to :data:`LEAD_PERIODS` periods, which
    ``compare`` allows below the lower bound.

    Without real-time frames the bounds are the request's and the reply's arrival on the proxy's
    clock, moved as :meth:`Session.controller_times` says, and a command's time is its request's on
    the period grid."""
    if not session.realtime:
        return _proxy_times(session)
    recv, ts = session.realtime.recv.tolist(), session.realtime.ts.tolist()
    bounds = []
    for req, rep in session.requests:
        i = bisect.bisect_right(recv, rep.t if rep is not None else req.t)
        k = bisect.bisect_left(recv, req.t) - 1
        bounds.append((ts[k] if k >= 0 else 0.0, ts[i] if i < len(ts) else math.inf))
    exact = [hi - req.t for (req, rep), (_, hi) in zip(session.requests, bounds, strict=True)
             if rep is not None and _is_queued(req.register) and math.isfinite(hi)]
    if not exact:
        exact = [hi - req.t for (req, _), (_, hi) in zip(session.requests, bounds, strict=True)
                 if math.isfinite(hi)]
    offset = float(np.median(exact)) if exact else 0.0
    out: list[tuple[float, float, float]] = []
    last = 0.0
    for (req, _), (lo, hi) in zip(session.requests, bounds, strict=True):
        if _pure_read(req):  # the earliest period it can have been answered in (see compare())
            t = lo
            hi += LEAD_PERIODS * PERIOD  # a frame may show the state before it was sent by that much
        else:
            t = min(max(lo, lo + round((req.t + offset - lo) / PERIOD) * PERIOD), hi)
        last = max(last, t)  # in the order the box received them
        out.append((last, max(last, hi), lo))
    return out


#: What a recording without the real-time report (port 30000) cannot show, said with its comparison.
COMMAND_PORT_ONLY = (
    "no real-time report (port 30000) in the recording: the requests are placed on the controller's clock "
    "by the proxy's (the first at the first control period), so a request's period is known only to "
    "within its round trip and the clock's phase",
    "path deviation is measured only at the program's own reads of the TCP pose (register 41) and the "
    "joints (register 42), as the distance of each recorded answer from the replayed path over the "
    "periods its round trip leaves open; such a read counts as a differing reply only beyond path_mm or "
    "path_deg",
    "not compared: move durations, joint torques and currents (they need the real-time report)",
)
#: Pure reads whose answers lie on the path: compared by distance without the real-time report.
PATH_READS = {41: "pose", 42: "joints"}


def _read_distance(c: CommandResult, rep: xrec.Rep, tries: list[bytes], cmd_only: bool,
                   tol: dict[str, float]) -> None:
    """For a pose or joint read still differing after its window (register 41 or 42): the distance
    of the recorded answer from the polyline of the replayed answers (mm for the pose's position,
    degrees for the joints). Without the real-time report, a read within the path tolerance is
    equal: the clock's phase is unknown there (:data:`COMMAND_PORT_ONLY`)."""
    key = PATH_READS.get(rep.register)
    reg = regs.get(rep.register)
    if key is None or reg is None or not c.reply_differs or not tries:
        return
    try:
        got = np.array(reg.reply.decode(rep.frame[8:])[key], dtype=float)
        path = np.array([reg.reply.decode(f[8:])[key] for f in tries], dtype=float)
    except (ValueError, KeyError, TypeError):
        return
    if key == "pose":
        d = float(np.linalg.norm(got[:3] - path[0, :3])) if len(path) == 1 else \
            float(min(_point_seg(got[:3], path[n, :3], path[n + 1, :3]) for n in range(len(path) - 1)))
        c.path_mm = d
        within = d <= tol.get("path_mm", 0.0)
    else:
        q, qs = np.degrees(got), np.degrees(path)
        d = float(np.linalg.norm(q - qs[0])) if len(qs) == 1 else \
            float(min(_point_seg(q, qs[n], qs[n + 1]) for n in range(len(qs) - 1)))
        c.path_deg = d
        within = d <= tol.get("path_deg", 0.0)
    if cmd_only and within:
        c.reply_differs = False


def _point_seg(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance of point ``p`` from the segment ``a``-``b``."""
    ab = b - a
    den = float(ab @ ab)
    u = 0.0 if den == 0 else min(1.0, max(0.0, float((p - a) @ ab) / den))
    return float(np.linalg.norm(p - (a + u * ab)))


def _proxy_times(session: Session) -> list[tuple[float, float, float]]:
    """:func:`_controller_times` of a recording of the command port only."""
    out: list[tuple[float, float, float]] = []
    last = 0.0
    for req, rep in session.requests:
        lo, hi = session.controller_times([req.t, rep.t if rep is not None else math.inf]).tolist()
        if _pure_read(req):  # the period it arrived in
            t, hi = math.floor(lo / PERIOD + 1e-9) * PERIOD, hi + LEAD_PERIODS * PERIOD
        else:
            t = max(PERIOD, round(lo / PERIOD) * PERIOD)
        last = max(last, t)
        out.append((last, max(last, hi), lo))
    return out


def _pure_read(req: xrec.Req) -> bool:
    return req.protocol in (2, 3) and req.register in PURE_READS and not req.params


def _seg_dist(points: np.ndarray, path: np.ndarray, window: int = 8) -> np.ndarray:
    """Distance of each of ``points`` from the polyline ``path`` (same length, aligned in time),
    looking at the segments within ``window`` samples."""
    n = len(points)
    best = np.full(n, np.inf)
    for first in range(0, n, DERIVE_ROWS):  # a batch of points at a time: bounded temporaries
        rows = np.arange(first, min(n, first + DERIVE_ROWS))
        p = points[rows]
        for k in range(-window, window):
            i0 = np.clip(rows + k, 0, n - 1)
            i1 = np.clip(i0 + 1, 0, n - 1)
            a, b = path[i0], path[i1]
            ab = b - a
            denom = np.einsum("ij,ij->i", ab, ab)
            u = np.where(denom > 0, np.einsum("ij,ij->i", p - a, ab) / np.where(denom > 0, denom, 1), 0)
            u = np.clip(u, 0.0, 1.0)
            d = np.linalg.norm(p - (a + u[:, None] * ab), axis=1)
            best[rows] = np.minimum(best[rows], d)
    return best


def _rms_where(d: np.ndarray, use: np.ndarray) -> float:
    """The largest per-joint RMS of the rows of ``d`` where ``use``."""
    return float(np.sqrt(np.mean(d[use] ** 2, axis=0)).max()) if use.any() else 0.0


def _blends(req: xrec.Req) -> bool:
    """Whether a request is a move with a blend radius (its path depends on when it arrived)."""
    radius = (req.values or {}).get("radius", 0)
    return isinstance(radius, (int, float)) and radius > 0


def _is_queued(register: int) -> bool:
    reg = regs.get(register)
    return reg is not None and reg.queued


def _duration(samples: Samples, start: int, end: int, t0: float) -> float | None:
    """From ``t0`` to the first sample at rest (state not 1) after one in motion, within the range."""
    moving = samples.state[start:end] == 1
    if not moving.any():
        return None
    first = int(np.argmax(moving))
    rest = ~moving[first:]
    if not rest.any():
        return None
    return float(samples.t[start + first + int(np.argmax(rest))]) - t0


#: Each candidate place's (joint, torque) distances from the frames, its first twin, its reply.
_Scores = tuple[list[tuple[float, float]], list[int], list[bytes]]
#: A read waiting to be answered again (``_Replay.retry``): its result, request, recorded reply, the
#: controller time after which it is given up, and the replayed answers it got so far.
_Pending = tuple[CommandResult, xrec.Req, xrec.Rep, float, list[bytes]]


class _Replay:
    """A fresh emulator on the stepped clock answering a session's requests in order (module
    docstring): the replayed samples taken at the recorded frames, the reads waiting to be answered
    again, and the cursors into the real-time frames (``j``) and the normal and rich frames (``k``,
    in controller-time order)."""

    def __init__(self, server: Any, emu: Any, session: Session, dof: int, tol: dict[str, float]) -> None:
        self.server, self.emu, self.session, self.dof, self.tol = server, emu, session, dof, tol
        self.cmd_only = not session.realtime
        self.spans = _controller_times(session)
        rt = session.realtime
        self.recorded = Samples(rt.ts, rt.state.astype(np.int64), rt.joints[:, :dof], rt.pos,
                                rt.torques[:, :dof], rt.currents[:, :dof], rt.speeds[:, :dof])
        self.rec_t = rt.ts.tolist()  # for the frame-by-frame loops
        self.replayed = Samples.empty(len(rt), dof)  # filled up to row j; positions etc. by derive()
        #: The settings that shape a sample's pose and torques, by their values: (group, a copy).
        self.settings: dict[tuple[float, ...], tuple[int, Any]] = {}
        self.group = np.zeros(len(rt), dtype=np.int64)  # each replayed sample's settings group
        self.qdd = np.zeros((len(rt), dof))  # each replayed sample's joint accelerations
        self.cmd_at: list[tuple[float, int]] = []  # (controller time, first sample) of every request
        self.emu_codes: list[tuple[int, int]] = [(0, 0)] * len(session.status)
        self.pending: list[_Pending] = []  # reads to try again
        status = session.status
        self.st_times = session.controller_times([f.t for f in status]).tolist() if status else []
        self.st_order = sorted(range(len(status)), key=lambda n: self.st_times[n])
        self.j = self.k = 0
        self.previous = 0.0  # the controller time of the request placed last
        self.slot = 0  # the slot (first real-time frame after it) of the command placed last
        self.ts = rt.ts
        self.windows = placement.windows(rt.recv, [(q.t, p.t if p is not None else None)
                                                   for q, p in session.requests]) if rt else []
        #: Each request's end of the frames that tell its candidate places apart: the first frame
        #: that may show the next command (a read changes nothing).
        self.until = [len(rt)] * len(session.requests)
        nxt = len(rt)
        for n in range(len(self.windows) - 1, -1, -1):
            self.until[n] = nxt
            if not _pure_read(session.requests[n][0]):
                nxt = self.windows[n].first

    @classmethod
    def start(cls, model: RobotModel, firmware: str, config_dir: Path, session: Session,
              tol: dict[str, float]) -> _Replay:
        """An emulator of ``model`` at ``firmware`` (its settings in ``config_dir``) on the stepped clock."""
        from ..controller.emulator import Emulator
        from ..server.core import EmulatorServer, ServerConfig

        emu = Emulator(model, config_dir=config_dir, firmware=firmware)
        server = EmulatorServer(emu, ServerConfig(stepped=True, port=0))
        return cls(server, emu, session, model.dof, tol)

    def advance(self, to: float) -> None:
        """Step the emulator to controller time ``to`` (:func:`~xarm_emu.server.placement.run_to`, as
        ``replay`` does), a period at a time while reads wait."""
        emu, server = self.emu, self.server
        while self.pending and to > emu.time + 1e-9:
            before = emu.time
            placement.run_to(server, min(to, emu.time + PERIOD))
            self.retry()
            if emu.time <= before:  # less than a period is left
                break
        placement.run_to(server, to)
        self.retry()

    def retry(self) -> None:
        """Answer every waiting read again: one answered as recorded compares equal, one past its
        upper bound is given up and measured by its distance from the path (:func:`_read_distance`)."""
        for item in list(self.pending):
            c, req, rep, hi, tries = item
            if self.emu.time > hi + 1e-9:
                self.pending.remove(item)
                _read_distance(c, rep, tries, self.cmd_only, self.tol)
                continue
            frame = self.server.answer(req.tid, req.protocol, req.register, req.params)
            tries.append(bytes(frame))
            if bytes(frame[6:]) == rep.frame[6:]:
                c.reply_differs, c.recorded_reply, c.replayed_reply = False, "", ""
                if c.reply_codes is not None:
                    c.reply_codes = (*c.reply_codes[:2], *c.reply_codes[:2])
                self.pending.remove(item)

    def give_up_reads(self) -> None:
        """Measure every waiting read by the answers it got and stop trying them."""
        for c_read, _, rep_read, _, tries in self.pending:
            _read_distance(c_read, rep_read, tries, self.cmd_only, self.tol)
        self.pending.clear()

    def sample_until(self, limit: float, slot: int | None = None) -> None:
        """Take the replayed state at every recorded frame before ``limit``: the joints, torques
        and currents at the real-time frames (those before index ``slot`` when given, the first frame
        that shows the command about to be answered), the error and warning codes at the normal and
        rich frames."""
        rec_t, st_order = self.rec_t, self.st_order
        while True:
            t_rt = rec_t[self.j] if self.j < len(rec_t) else math.inf
            t_st = self.st_times[st_order[self.k]] if self.k < len(st_order) else math.inf
            rt_due = t_rt < limit - 1e-9 if slot is None else self.j < slot
            st_due = t_st < limit - 1e-9
            if not (rt_due or st_due):
                return
            if st_due and (not rt_due or t_st <= t_rt):  # the state of the last period begun by then
                self.advance(math.floor(t_st / PERIOD + 1e-9) * PERIOD)
                ctl = self.emu.controller
                self.emu_codes[st_order[self.k]] = (ctl.error_code, ctl.warning_code)
                self.k += 1
                continue
            self.take(rec_t[self.j])

    def take(self, t: float) -> None:
        """Sample the replayed state at the next real-time frame, stamped ``t``."""
        self.advance(t)
        ctl = self.emu.controller
        d, s = ctl.data, ctl.settings
        key = (*s.tcp_offset, *s.world_offset, *s.tcp_load, *s.gravity_direction)
        group = self.settings.get(key)
        if group is None:
            group = self.settings[key] = (len(self.settings), copy.deepcopy(s))
        dof, j, rep = self.dof, self.j, self.replayed
        self.group[j] = group[0]
        self.qdd[j] = d.qdd[:dof]
        rep.t[j], rep.state[j], rep.joints[j], rep.speeds[j] = t, d.motion_state, d.q[:dof], d.qd[:dof]
        self.j += 1

    def derive(self) -> None:
        """The TCP positions, joint torques and currents of every replayed sample, computed in one
        batch per set of settings that shape them (TCP and user offsets, payload, gravity direction)
        once the replay is over: the same functions the box's reports use, on arrays
        (``kinematics.tcp_positions``, ``controller.joint_torques_many``)."""
        rep = self.replayed = self.replayed.head(self.j)
        if not len(rep):
            return
        model = self.emu.controller.model
        q, qd, qdd, which = rep.joints, rep.speeds, self.qdd[:self.j], self.group[:self.j]
        for n, s in self.settings.values():
            rows = np.flatnonzero(which == n)
            for a in range(0, len(rows), DERIVE_ROWS):  # a batch at a time: their temporaries are large
                r = rows[a:a + DERIVE_ROWS]
                rep.pos[r] = kin.tcp_positions(model, q[r], s.tcp_offset, s.world_offset)
                rep.torques[r] = joint_torques_many(model, q[r], qd[r], qdd[r], s)
        for a in range(0, len(rep), DERIVE_ROWS):
            rep.currents[a:a + DERIVE_ROWS] = dyn.torques_to_currents(model, rep.torques[a:a + DERIVE_ROWS])

    def time_of(self, i: int, req: xrec.Req) -> float:
        """The controller time request ``i`` is answered at when no real-time frames place it
        (:func:`_controller_times`), the state sampled up to its lower bound first: a read at its
        earliest period, a queued command at its estimate, any other at its lower bound."""
        t_est, _, lo = self.spans[i]
        lower = max(self.previous, lo - LEAD_PERIODS * PERIOD)
        self.sample_until(lower)  # no command can come before its lower bound
        if _pure_read(req):
            return max(lower, self.emu.time)
        if _is_queued(req.register):
            return max(t_est, lower)
        return max(lo, lower)  # the earliest its bounds allow, so a queued command after it can be placed

    def position(self, i: int, req: xrec.Req) -> tuple[float, int, str]:
        """The place (controller time, slot) of command ``i`` among those its frames leave open
        (:func:`.placement.candidates`) and how it was chosen (:data:`PLACEMENTS`): the one after
        which the replayed joints, then the joint torques, follow the recorded frames most closely up
        over the frames after them, the commands after it applied (:meth:`score`); of places that
        give the same frames the earliest, of others alike the one nearest the proxy clock's estimate."""
        t_est = self.spans[i][0]
        answer = self.session.requests[i][1]
        late = t_est + (answer.t - req.t if answer is not None else 0.0)  # answered when the reply left
        cands = placement.nearest(placement.candidates(self.ts, self.windows[i], (self.previous, self.slot)),
                                  (t_est, late))
        s0 = min(s for _, s in cands)
        self.sample_until(cands[0][0], s0)  # the frames before every candidate: alike for all
        if len(cands) == 1:
            return (*cands[0], "bounds")
        moving = self.emu.controller.data.motion_state == 1
        lengths = (FIRST_FRAMES, SEARCH_FRAMES) + ((BLEND_FRAMES,) if _blends(req) else ())
        for frames in lengths:  # a few frames tell most places apart
            end = min(len(self.rec_t), max(s for _, s in cands) + frames)
            scores, twins, replies = self.score(req, cands, s0, end, self.followers(i, end))
            rep = self.session.requests[i][1]
            if rep is not None and any(r == rep.frame[6:] for r in replies):  # answered as recorded
                scores = [sc if r == rep.frame[6:] else (math.inf, math.inf) for sc, r in zip(scores, replies,
                                                                                             strict=True)]
            best_q = min(q for q, _ in scores)
            alike = [n for n, (q, _) in enumerate(scores) if q <= best_q + 1e-9]
            best_tau = min(scores[n][1] for n in alike)
            alike = [n for n in alike if scores[n][1] <= best_tau + 1e-9]
            decided = len({twins[n] for n in alike}) == 1  # the best places gave the same frames
            if decided and len(set(twins)) > 1 or len(set(twins)) == 1 and (not _is_queued(req.register)
                                                                             or moving and not _blends(req)):
                break  # told apart, or alike: a setting, or a move queued behind one (starts when it ends)
        if len({twins[n] for n in alike}) == 1:  # places alike in every frame: the earliest, which
            best = alike[0]  # leaves the commands after it every place they can have
        else:
            best = min(alike, key=lambda n: (abs(cands[n][0] - t_est), n))
        return (*cands[best], "frames" if decided and len(set(twins)) > 1 else
                "alike" if len(set(twins)) == 1 else "estimate")

    def followers(self, i: int, end: int) -> list[tuple[xrec.Req, float, int]]:
        """The commands after request ``i`` that may show in frames before ``end``, each with the
        place of the proxy clock's estimate (its request, controller time, slot), for :meth:`score`."""
        out = []
        n = i + 1
        while n < len(self.windows) and self.windows[n].first < end:
            req = self.session.requests[n][0]
            if not _pure_read(req):  # at the proxy clock's estimate within its window
                w, ts = self.windows[n], self.ts
                lo = float(ts[w.first - 1]) if w.first else 0.0
                hi = float(ts[w.last]) if w.last < len(ts) else math.inf
                t = min(max(self.spans[n][0], lo), hi)
                out.append((req, t, max(w.first, int(np.searchsorted(ts, t - 1e-9)))))
            n += 1
        return out

    def score(self, req: xrec.Req, cands: list[tuple[float, int]], s0: int, end: int,
              after: list[tuple[xrec.Req, float, int]]) -> _Scores:
        """For each candidate place of ``req``: how far the replayed joints (rad, beyond a float32's
        rounding) and joint torques (N m) are from the recorded frames ``s0``..``end``, the command
        answered at its place and the commands ``after`` it at their earliest places (alike for
        every candidate), from a checkpoint restored after each try. The torques, computed in a
        batch, only of the places whose joints follow the frames best (else ``inf``). And each
        place's first twin: the first place that gave the same joints, speeds, accelerations, state
        and settings at every frame; and the reply each place got (from the state byte on). A frame
        whose state differs counts :data:`STATE_WEIGHT` in the joint distance."""
        emu, server, rec, rec_t = self.emu, self.server, self.recorded, self.rec_t
        model, dof = emu.controller.model, self.dof
        rec_q = rec.joints[s0:end]
        rec_state = rec.state[s0:end].tolist()
        cp = emu.checkpoint()
        runs = []
        replies: list[bytes] = []
        for n, (t, s) in enumerate(cands):
            if n:
                emu.restore(cp)
            states: list[np.ndarray] = []
            motion: list[int] = []  # each frame's state (register 13)
            settings: list[tuple[float, ...]] = []  # each frame's settings, by their values
            kinds: dict[tuple[float, ...], Any] = {}
            todo = [(t, s, req)]
            for f_req, f_t, f_s in after:
                t_prev, s_prev = todo[-1][:2]
                todo.append((max(f_t, t_prev), max(f_s, s_prev), f_req))
            for k in range(s0, max(end, s + 1)):
                while todo and todo[0][1] == k:
                    when, _, what = todo.pop(0)
                    placement.run_to(server, when)
                    frame = server.answer(what.tid, what.protocol, what.register, what.params)
                    if what is req:
                        replies.append(bytes(frame[6:]))
                if k >= end:
                    break
                placement.run_to(server, rec_t[k])
                d = emu.controller.data
                states.append(np.concatenate((d.q[:dof], d.qd[:dof], d.qdd[:dof])))
                motion.append(d.motion_state)
                st = emu.controller.settings
                key = (*st.tcp_offset, *st.world_offset, *st.tcp_load, *st.gravity_direction)
                if key not in kinds:
                    kinds[key] = copy.deepcopy(st)
                settings.append(key)
            x = np.array(states).reshape(len(states), 3, dof)
            err_q = float(np.maximum(np.abs(x[:, 0] - rec_q) - JOINT_ROUNDING, 0.0).sum()) if len(x) else 0.0
            err_q += STATE_WEIGHT * sum(m != r for m, r in zip(motion, rec_state, strict=False))
            runs.append((err_q, x, (settings, motion), kinds))
        emu.restore(cp)
        twins = [next(m for m in range(n + 1) if np.array_equal(runs[m][1], runs[n][1])
                      and runs[m][2] == runs[n][2]) for n in range(len(runs))]
        best_q = min(r[0] for r in runs)
        best = [n for n, r in enumerate(runs) if r[0] <= best_q + 1e-9 and len(r[1])]
        out = [(r[0], math.inf if len(r[1]) else 0.0) for r in runs]
        if len(best) == 1:
            out[best[0]] = (best_q, 0.0)
        for n in best if len(best) > 1 else []:
            if twins[n] != n:  # the same frames as a place scored already
                out[n] = out[twins[n]]
                continue
            err_q, x, (settings, _), kinds = runs[n]
            tau = np.empty((len(x), dof))
            for key, st in kinds.items():  # the frames under each settings, in a batch
                rows = np.array([x_key == key for x_key in settings])
                tau[rows] = joint_torques_many(model, x[rows, 0], x[rows, 1], x[rows, 2], st)
            rec_tau = rec.torques[s0:s0 + len(x)]
            out[n] = (err_q, float(np.abs(tau - rec_tau).sum()))
        return out, twins, replies

    def place(self, i: int, req: xrec.Req, rep: xrec.Rep | None) -> CommandResult:
        """Answer request ``i`` at its place and compare the reply with the recorded one."""
        read = _pure_read(req)
        _, hi, lo = self.spans[i]
        if read or not self.recorded:
            t = self.previous = self.time_of(i, req)
            self.sample_until(t)
            how = "read" if read else "clock"
            window = (lo, hi) if read else (min(lo, t), max(hi, t))
            open_ = not read and placement.undecided(*window)
        else:
            t, slot, how = self.position(i, req)
            self.previous, self.slot = t, slot
            self.sample_until(t, slot)
            ts, w = self.ts, self.windows[i]
            window = (float(ts[w.first - 1]) if w.first else t,
                      float(ts[w.last]) if w.last < len(ts) else math.inf)
            open_ = how == "estimate"
        self.advance(t)
        if not read and self.pending:  # a command may change what a read shows: look ahead first
            cp = self.emu.checkpoint()
            self.advance(max(item[3] for item in self.pending))
            self.emu.restore(cp)
            self.give_up_reads()
        frame = self.server.answer(req.tid, req.protocol, req.register, req.params)
        c = CommandResult(i, t, req.register, req.name, window=window, placed_by=how, undecided=open_)
        if req.register == ERR_WARN_REGISTER and rep is not None and min(len(rep.frame), len(frame)) > 9:
            c.reply_codes = (rep.frame[8], rep.frame[9], frame[8], frame[9])
        if rep is not None and bytes(frame[6:]) != rep.frame[6:]:
            c.reply_differs = True
            c.recorded_reply, c.replayed_reply = rep.frame[6:].hex(), bytes(frame[6:]).hex()
            if read:
                self.pending.append((c, req, rep, self.spans[i][1], [bytes(frame)]))
        self.cmd_at.append((t, self.j))
        return c

    def finish(self) -> None:
        """Sample the frames after the last request and try the reads still waiting over their periods."""
        self.sample_until(math.inf)
        if self.pending:  # reads after the last frame (or in a recording without frames): their periods
            self.advance(max(item[3] for item in self.pending) + PERIOD)
            self.give_up_reads()


def compare(path: Path, calibration: Calibration | None = None,
            tolerances: dict[str, float] | None = None,
            progress: Callable[[int, int], object] | None = None) -> Comparison:
    """Replay the recording at ``path`` and measure the differences (module docstring);
    ``progress(done, total)`` is called as the requests are replayed."""
    import time as _time

    tol = tolerances or dict(DEFAULT_TOLERANCES)
    session = read_session(Path(path))
    base = model_of(session.version)
    model = with_calibration(base, calibration)
    firmware = str(session.profile.version)
    result = Comparison(base.key, firmware, session=session, tolerances=dict(tol))
    if not session.realtime:
        result.notes = list(COMMAND_PORT_ONLY)
    started = _time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="xarm-emu-compare-") as cdir:
        replay = _Replay.start(model, firmware, Path(cdir), session, tol)
        for i, (req, rep) in enumerate(session.requests):
            result.commands.append(replay.place(i, req, rep))
            if progress is not None and i % 256 == 0:
                progress(i, len(session.requests))
        replay.finish()
        replay.derive()
        result.replay_seconds = _time.perf_counter() - started
    result.recorded, result.replayed = replay.recorded, replay.replayed
    _measure(result, replay.cmd_at, tol, session, replay.emu_codes)
    return result


def _measure(result: Comparison, cmd_at: list[tuple[float, int]], tol: dict[str, float],
             session: Session, emu_codes: list[tuple[int, int]]) -> None:
    rec, rep = result.recorded, result.replayed
    if rec:
        d_mm = _seg_dist(rec.pos, rep.pos)
        d_deg = _seg_dist(np.degrees(rec.joints), np.degrees(rep.joints))
        dtau, dcur = rec.torques - rep.torques, rec.currents - rep.currents
        has = ~np.isnan(dtau[:, 0])
    else:  # a recording of the command port only (COMMAND_PORT_ONLY)
        d_mm, d_deg, dtau, dcur = np.zeros(0), np.zeros(0), np.zeros((0, 1)), np.zeros((0, 1))
        has = np.zeros(0, dtype=bool)
    dtau, dcur = np.where(np.isnan(dtau), 0.0, dtau), np.where(np.isnan(dcur), 0.0, dcur)
    inside = _inside_windows(result.commands, rec.t, session.requests)
    d_mm, d_deg = np.where(inside, 0.0, d_mm), np.where(inside, 0.0, d_deg)
    dtau, dcur = np.where(inside[:, None], 0.0, dtau), np.where(inside[:, None], 0.0, dcur)
    has = has & ~inside
    rms = _rms_where
    bounds = [j for _, j in cmd_at] + [len(rec)]
    for n, c in enumerate(result.commands):
        a, b = bounds[n], bounds[n + 1]
        c.samples = (a, b)
        c.excluded_frames = int(inside[a:b].sum())
        if b > a:
            c.path_mm, c.path_deg = float(d_mm[a:b].max()), float(d_deg[a:b].max())
            h = has[a:b]
            c.torque_rms, c.current_rms = rms(dtau[a:b], h), rms(dcur[a:b], h)
            c.torque_max = float(np.abs(dtau[a:b]).max())
            c.current_max = float(np.abs(dcur[a:b]).max())
    queued = [n for n, c in enumerate(result.commands) if _is_queued(c.register)] + [len(result.commands)]
    for m, n in enumerate(queued[:-1]):  # a move lasts at most until the next queued command
        c = result.commands[n]
        end = bounds[queued[m + 1]]
        d_rec, d_rep = _duration(rec, bounds[n], end, c.t), _duration(rep, bounds[n], end, c.t)
        if d_rec is not None or d_rep is not None:
            c.duration = (d_rec if d_rec is not None else math.nan, d_rep if d_rep is not None else math.nan)
    durations = [_duration_difference(c) for c in result.commands if c.duration]
    t = result.totals
    t["requests"] = len(result.commands)
    t["samples"] = len(rec)
    t["reply_differences"] = sum(c.reply_differs and c.inside is None for c in result.commands)
    t["undecided"] = sum(c.undecided for c in result.commands)  # placed within a window, not a period
    t["undecided_replies"] = sum(c.reply_differs and c.inside is not None for c in result.commands)
    t["excluded_frames"] = int(inside.sum())
    t["duration_s"] = max((d if math.isfinite(d) else math.inf for d in durations), default=0.0)
    reads = result.commands  # a read's own distance (a recording without the real-time report)
    t["path_mm"] = max(float(d_mm.max(initial=0.0)), max((c.path_mm for c in reads), default=0.0))
    t["path_deg"] = max(float(d_deg.max(initial=0.0)), max((c.path_deg for c in reads), default=0.0))
    t["torque_max"] = float(np.abs(dtau).max(initial=0.0))
    t["current_max"] = float(np.abs(dcur).max(initial=0.0))
    t["torque_rms"] = t["current_rms"] = 0.0
    if has.any():
        jt = np.sqrt(np.mean(dtau[has] ** 2, axis=0))
        jc = np.sqrt(np.mean(dcur[has] ** 2, axis=0))
        t["torque_rms"], t["current_rms"] = float(jt.max()), float(jc.max())
        result.per_joint = {"torque_rms": jt.tolist(), "current_rms": jc.tolist(),
                            "torque_mean": dtau[has].mean(axis=0).tolist(),
                            "current_mean": dcur[has].mean(axis=0).tolist()}
    t["code_differences"], t["code_timing_s"] = _codes(result, session, emu_codes)
    nominal = reports.rates_for(session.profile)
    worst_rate = 0.0
    for conn, (port, stamps) in sorted(session.streams.items()):  # each reader sees the whole stream
        if len(stamps) > 10 and port in nominal and stamps[-1] > stamps[0]:
            rate = (len(stamps) - 1) / (stamps[-1] - stamps[0])
            rel = abs(rate - nominal[port]) / nominal[port]
            result.rate_connections.append({"conn": conn, "port": port, "frames": len(stamps), "rate": rate})
            if str(port) not in result.rates or rel >= abs(result.rates[str(port)][0] / nominal[port] - 1):
                result.rates[str(port)] = [rate, nominal[port]]
            worst_rate = max(worst_rate, rel)
    t["report_rate_rel"] = worst_rate
    for key, limit in tol.items():
        if t.get(key, 0.0) > limit:
            result.failures.append(f"{key} {t[key]:.6g} > {limit:.6g}")


def _inside_windows(commands: list[CommandResult], ts: np.ndarray,
                    requests: list[tuple[xrec.Req, xrec.Rep | None]]) -> np.ndarray:
    """Which real-time frames (stamped ``ts``) lie inside the window of an undecided command, whose
    effect the recording cannot place on one period: they are left out of the path, torque and current
    measures. A request whose round trip overlaps such a command's on the proxy's clock (another
    connection's: the box may have answered it before or after the command) gets the command's index
    as ``inside``: its reply is not counted as a difference."""
    out = np.zeros(len(ts), dtype=bool)
    spans = sorted((requests[c.index][0].t, _reply_time(requests[c.index]), c.index)
                   for c in commands if c.undecided)
    if not spans:
        return out
    for c in commands:
        if c.undecided:
            lo, hi = c.window
            out[np.searchsorted(ts, lo - 1e-9, "left"):np.searchsorted(ts, hi + 1e-9, "right")] = True
    unanswered = [(a, n) for a, b, n in spans if not math.isfinite(b)]  # never answered: open to the end
    spans = [x for x in spans if math.isfinite(x[1])]
    starts = [a for a, _, _ in spans]
    longest = max((b - a for a, b, _ in spans), default=0.0)
    for c in commands:
        req_t, rep_t = requests[c.index][0].t, _reply_time(requests[c.index])
        c.inside = next((n for a, n in unanswered if n != c.index and a < rep_t), None)
        k = bisect.bisect_left(starts, rep_t) - 1  # undecided commands asked before this reply
        while k >= 0 and starts[k] >= req_t - longest and c.inside is None:
            a, b, n = spans[k]
            if n != c.index and b > req_t:  # its reply after this request: the round trips overlap
                c.inside = n
            k -= 1
    return out


def _reply_time(pair: tuple[xrec.Req, xrec.Rep | None]) -> float:
    return pair[1].t if pair[1] is not None else math.inf


def _duration_difference(c: CommandResult) -> float:
    """A move's duration recorded against replayed; for an undecided command less its window's width
    (its start is known only within it)."""
    assert c.duration is not None
    d = abs(c.duration[0] - c.duration[1])
    if c.undecided and math.isfinite(d):
        d = max(0.0, d - (c.window[1] - c.window[0]))
    return d


def _code_name(kind: int, code: int) -> str:
    return f"{'EW'[kind]}{code}"


def _codes(result: Comparison, session: Session, emu_codes: list[tuple[int, int]]) -> tuple[float, float]:
    """The error and warning codes (manual 3.2) the box showed against the emulator's at the same
    instants, into ``result.codes``; returns (differences, the largest difference in the time a code
    was first seen, s).

    - ``reports``: every normal and rich report frame (bytes 89 and 90, manual 2.1.6) whose codes
      differ from the emulator's at its controller time, one row per run of frames alike:
      ``{t, port, frames, recorded: [error, warning], emulator: [error, warning]}``;
    - ``replies``: replies to register 15 (get_err_warn_code) that differ, with both codes;
    - ``state_bits``: replies whose error or warning bits (state byte 0x40, 0x20) differ;
    - ``first_seen``: each code either side showed, with the controller time it first showed it in
      a report frame or a register 15 reply (``None``: never).

    Differences: the codes seen on one side only, the register 15 replies and the state bits that
    differ (a run of differing report frames is counted through its codes).
    """
    codes: dict[str, list[Any]] = {}
    seen: dict[str, list[float | None]] = {}

    def saw(name: str, side: int, t: float) -> None:
        first = seen.setdefault(name, [None, None])
        if first[side] is None or t < first[side]:  # type: ignore[operator]
            first[side] = t

    st_times = session.controller_times([f.t for f in session.status]).tolist() if session.status else []
    runs: list[dict[str, Any]] = []
    last: dict[int, tuple[int, int, int, int]] = {}
    for f, t, emu in zip(session.status, st_times, emu_codes, strict=True):
        rec = (f.error, f.warning)
        for side, pair in ((0, rec), (1, emu)):
            for kind, code in enumerate(pair):
                if code:
                    saw(_code_name(kind, code), side, t)
        key = (*rec, *emu)
        if rec != emu:
            if last.get(f.port) == key:
                runs[-1]["frames"] += 1
            else:
                runs.append({"t": t, "port": f.port, "frames": 1, "recorded": list(rec),
                             "emulator": list(emu)})
        last[f.port] = key
    if runs:
        codes["reports"] = runs
    replies, bits = [], []
    for c in result.commands:
        if c.reply_codes is not None:
            for kind in (0, 1):
                for side in (0, 1):
                    if c.reply_codes[2 * side + kind]:
                        saw(_code_name(kind, c.reply_codes[2 * side + kind]), side, c.t)
            if c.reply_codes[:2] != c.reply_codes[2:] and c.inside is None:  # not inside a window
                replies.append({"t": c.t, "request": c.index, "recorded": list(c.reply_codes[:2]),
                                "emulator": list(c.reply_codes[2:])})
        if c.reply_differs and c.inside is None and c.recorded_reply and c.replayed_reply:
            rs, ps = int(c.recorded_reply[2:4], 16), int(c.replayed_reply[2:4], 16)
            if (rs ^ ps) & 0x60:
                bits.append([c.t, float(c.register), float(rs & 0x60), float(ps & 0x60)])
    if replies:
        codes["replies"] = replies
    if bits:
        codes["state_bits"] = bits
    if seen:
        codes["first_seen"] = [{"code": name, "recorded": r, "emulator": e}
                               for name, (r, e) in sorted(seen.items())]
    result.codes = codes
    one_side = sum((r is None) != (e is None) for r, e in seen.values())
    timing = max((abs(r - e) for r, e in seen.values() if r is not None and e is not None), default=0.0)
    return float(one_side + len(replies) + len(bits)), float(timing)


#: Periods by which a real-time frame's timestamp may lead the controller time of the commands
#: answered after it was received (a frame is prepared for its deadline ahead of sending it).
LEAD_PERIODS = 2
#: Real-time frames after a command's latest candidate place over which the places are told apart:
#: first a few, then, when they leave several places alike, more; for a move blended into the one
#: before it (its arrival decides the blend, which shows when the arm gets there), up to 2 s.
FIRST_FRAMES, SEARCH_FRAMES, BLEND_FRAMES = 4, 25, 500
#: Joints (rad) a replayed frame may be from a recorded one, the recorded float32's rounding, before
#: it counts against a candidate place.
JOINT_ROUNDING = 1e-6
#: What a frame whose state (moving, stopped, ...) differs from the recorded one adds to a candidate
#: place's joint distance (rad): more than any joint difference a place can make.
STATE_WEIGHT = 10.0
#: How a command's period was chosen (``placed_by``): ``bounds`` (its frames leave one place),
#: ``frames`` (the place after which the replay follows the recorded frames best, or places that
#: give the same frames), ``alike`` (every place gives the same frames: the command shows nowhere
#: near it; the proxy clock's estimate), ``estimate`` (places that give different frames follow the
#: recorded ones alike: the proxy clock's estimate, ``undecided``), ``read`` (a pure
#: read, tried at every period its round trip leaves open), ``clock`` (no real-time report: the
#: proxy's clock, ``undecided`` when its round trip leaves more than one period open).
PLACEMENTS = ("bounds", "frames", "alike", "estimate", "read", "clock")


def code_lines(result: Comparison) -> list[str]:
    """One line per error or warning code either side showed: when, recorded against the emulator."""
    out = []
    for row in result.codes.get("first_seen", []):
        r, e = row["recorded"], row["emulator"]
        rec = "never" if r is None else f"{r:.3f} s"
        emu = "never" if e is None else f"{e:.3f} s"
        out.append(f"code {row['code']}: first seen recorded {rec}, emulator {emu}")
    for row in result.codes.get("replies", []):
        out.append(f"get_err_warn_code at {row['t']:.3f} s: recorded error {row['recorded'][0]} warning "
                   f"{row['recorded'][1]}, emulator error {row['emulator'][0]} warning {row['emulator'][1]}")
    return out
