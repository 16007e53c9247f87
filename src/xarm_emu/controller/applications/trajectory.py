"""Trajectory recording, saving, loading and playback (registers 61-65 and 230).

- Register 61 ``[1]`` starts recording the joints, one sample per control period (so a hand-guided
  motion in joint teaching mode, mode 2, is kept exactly), ``[0]`` stops; a recording ends by itself
  after :data:`MAX_RECORD_SECONDS`.
- Register 62 saves the recording under a name (the SDK appends ``.traj``) in the ``trajectories``
  folder of the configuration directory: written to a temporary file, flushed and renamed, so a
  file is either complete or absent and survives restarts. Register 63 loads one.
  Register 65 answers the status of the last save or load (0 idle, 1 loading, 2 load ok,
  3 load failed, 4 saving, 5 save ok, 6 save failed).
- Register 64 plays the loaded trajectory ``times`` times (-1: until stopped) at the recorded speed
  times the factor (1, 2 or 4). The arm first moves (a joint move from rest) to the first recorded
  point, then passes through every recorded joint position (every ``factor``-th sample: each
  control period advances ``factor`` recorded periods). The mode reads 11 during playback (what the
  SDK waits for), state 1; at the end the mode returns to 0 and the state to 2.

Names are ASCII letters, digits, ``-``, ``_``, ``.`` and spaces, at most 80 characters, no path parts.
Feedback (``FirmwareProfile.feedback``, registers 253/254): where the controller has a feedback queue (a
component with ``capture``, ``start_other`` and ``finish_other``), a save, load or playback reports
OTHER_START when accepted and OTHER_FINISH (code 0, or 1 when it failed) when it ends, to the
connection and transaction that asked for it; the SDK's ``wait=True`` waits for that frame.
:attr:`TrajectoryStore.on_finish` is called as well, with the register and the code.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np

from ...model import kinematics as kin
from .. import motion
from ..core.controller_protocol import Controller
from ..core.controller_state import part_of
from ..core.state_machine import MODE_PLAYBACK, STATE_MOVING, STATE_SLEEP, Event, ModeEvent, fire, fire_mode

#: Longest recording (s of controller time); recording stops by itself after it.
MAX_RECORD_SECONDS = 300.0

#: Register 65's status values.
IDLE, LOADING, LOAD_OK, LOAD_FAILED, SAVING, SAVE_OK, SAVE_FAILED = range(7)

#: Playback speed factors register 64 accepts.
SPEED_FACTORS = (1, 2, 4)

#: Joint speed and acceleration of the move to the first recorded point (rad/s, rad/s^2).
LEAD_IN_SPEED = 0.35
LEAD_IN_ACC = 5.0

_NAME = re.compile(r"^[A-Za-z0-9_\-. ]{1,80}$")
_FORMAT = "xarm-emu trajectory"


class TrajectoryError(ValueError):
    """A name that is not a valid trajectory file name, or a file that is not a trajectory."""


def valid_name(name: str) -> str:
    """``name`` if it is a valid trajectory file name, else :class:`TrajectoryError`."""
    if not _NAME.match(name) or name.strip(". ") == "" or ".." in name:
        raise TrajectoryError(f"not a trajectory name: {name!r}")
    return name


@dataclass
class Playback:
    samples: np.ndarray  # (n, dof)
    factor: int
    times: int  # -1: forever
    lead_in: motion.JointTrajectory | None
    t: float = 0.0
    index: float = 0.0
    done_times: int = 0
    #: Who asked for the playback, for its OTHER_FINISH feedback.
    origin: Any = None


def _feedback_queue(ctl: Controller) -> Any:
    """The controller's feedback queue component, if it has one."""
    for c in ctl.components:
        if all(hasattr(c, name) for name in ("capture", "start_other", "finish_other")):
            return c
    return None


def _started(ctl: Controller, register: int) -> Any:
    """OTHER_START of a trajectory task just accepted; returns its origin for the finish."""
    fq = _feedback_queue(ctl)
    if fq is None:
        return None
    origin = fq.capture()
    fq.start_other(origin, register, ctl.time)
    return origin


def _finished(ctl: Controller, origin: Any, register: int, code: int) -> None:
    fq = _feedback_queue(ctl)
    if fq is not None:
        fq.finish_other(origin, register, ctl.time, ok=code == 0)


@dataclass(slots=True)
class TrajectoryStore:
    """Recording, the loaded trajectory, the files and the playback of one controller."""

    directory: Path | None = None
    recording: bool = False
    recorded: list[np.ndarray] = field(default_factory=list)
    record_period: float = 0.004
    loaded: np.ndarray | None = None
    loaded_period: float = 0.004
    status: int = IDLE
    playback: Playback | None = None
    #: In-memory files when there is no configuration directory.
    memory: dict[str, bytes] = field(default_factory=dict)
    on_finish: Callable[[int, int], None] | None = None

    # -- files -------------------------------------------------------------------------------
    def _path(self, name: str) -> Path | None:
        return None if self.directory is None else self.directory / valid_name(name)

    def write(self, name: str, samples: list[np.ndarray], period: float, dof: int) -> None:
        data = json.dumps({"format": _FORMAT, "version": 1, "period": period, "dof": dof,
                           "joints": [[float(x) for x in q] for q in samples]}).encode()
        path = self._path(name)
        if path is None:
            self.memory[valid_name(name)] = data
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise
        with contextlib.suppress(OSError):
            dfd = os.open(path.parent, os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)

    def read(self, name: str, dof: int) -> tuple[np.ndarray, float]:
        path = self._path(name)
        raw = self.memory[valid_name(name)] if path is None else path.read_bytes()
        try:
            data = json.loads(raw)
            joints = np.asarray(data["joints"], dtype=float)
            period = float(data["period"])
        except (ValueError, KeyError, TypeError) as exc:
            raise TrajectoryError(f"{name}: not a trajectory file") from exc
        if (data.get("format") != _FORMAT or joints.ndim != 2 or joints.shape[0] == 0
                or joints.shape[1] != dof or not np.all(np.isfinite(joints)) or not period > 0.0):
            raise TrajectoryError(f"{name}: not a trajectory of this arm")
        return joints, period

    def finish(self, register: int, code: int) -> None:
        if self.on_finish is not None:
            self.on_finish(register, code)


def store_of(ctl: Controller) -> TrajectoryStore:
    """The trajectory store of ``ctl`` (in memory until :func:`attach` gives it a directory)."""
    return part_of(ctl.data, "trajectory_store", lambda: TrajectoryStore(record_period=ctl.period))


def attach(ctl: Controller, config_dir: Path | None) -> TrajectoryStore:
    """Keep ``ctl``'s trajectory files in ``config_dir/trajectories``."""
    st = store_of(ctl)
    st.directory = None if config_dir is None else Path(config_dir) / "trajectories"
    return st


# -- recording (register 61) --------------------------------------------------------------------
def set_recording(ctl: Controller, on: bool) -> None:
    st = store_of(ctl)
    if on:
        st.recorded = [ctl.q.copy()]
        st.record_period = ctl.period
    st.recording = on


def record_step(ctl: Controller, dt: float) -> None:
    """Every control period: keep the joints while recording; a playback whose mode 11 was left
    (register 19) ends unfinished."""
    st = cast("TrajectoryStore | None", ctl.data.trajectory_store)
    if st is None:
        return
    if st.playback is not None and ctl.mode != MODE_PLAYBACK:
        _finished(ctl, st.playback.origin, 64, 1)
        st.playback = None
    if not st.recording:
        return
    st.recorded.append(ctl.q.copy())
    if (len(st.recorded) - 1) * st.record_period >= MAX_RECORD_SECONDS:
        st.recording = False


def record_idle(ctl: Controller) -> bool:
    """:func:`record_step` would change nothing now: no recording, no playback left unfinished."""
    st = cast("TrajectoryStore | None", ctl.data.trajectory_store)
    return st is None or (not st.recording and (st.playback is None or ctl.mode == MODE_PLAYBACK))


def save(ctl: Controller, name: str) -> int:
    """Register 62: save the recording; returns register 65's status."""
    st = store_of(ctl)
    origin = _started(ctl, 62)
    st.status = SAVING
    try:
        if len(st.recorded) < 2:
            raise TrajectoryError("nothing recorded")
        st.write(name, st.recorded, st.record_period, ctl.dof)
        st.status = SAVE_OK
    except (TrajectoryError, OSError):
        st.status = SAVE_FAILED
    _finished(ctl, origin, 62, 0 if st.status == SAVE_OK else 1)
    st.finish(62, 0 if st.status == SAVE_OK else 1)
    return st.status


def load(ctl: Controller, name: str) -> int:
    """Register 63: load a saved trajectory; returns register 65's status."""
    st = store_of(ctl)
    origin = _started(ctl, 63)
    st.status = LOADING
    try:
        st.loaded, st.loaded_period = st.read(name, ctl.dof)
        st.status = LOAD_OK
    except (TrajectoryError, OSError, KeyError):
        st.status = LOAD_FAILED
    _finished(ctl, origin, 63, 0 if st.status == LOAD_OK else 1)
    st.finish(63, 0 if st.status == LOAD_OK else 1)
    return st.status


# -- playback (register 64, mode 11) -----------------------------------------------------------
def start_playback(ctl: Controller, times: int, factor: int) -> None:
    """Start playing the loaded trajectory (checked by the caller)."""
    st = store_of(ctl)
    assert st.loaded is not None
    samples = st.loaded
    if not all(kin.within_limits(ctl.model, q) for q in samples[:: max(1, len(samples) // 200)]):
        raise TrajectoryError("the trajectory leaves the joint limits")
    lead_in = None
    if float(np.max(np.abs(samples[0] - ctl.q))) > 1e-9:
        s = ctl.settings
        lead_in = motion.plan_joint_move(ctl.q, samples[0], LEAD_IN_SPEED, min(LEAD_IN_ACC, s.joint_maxacc),
                                         s.joint_jerk)
    st.playback = Playback(samples, factor, times, lead_in, origin=_started(ctl, 64))
    fire_mode(ctl, ModeEvent.PLAYBACK_START)
    fire(ctl, Event.SERVO_MOVING)


def _end_playback(ctl: Controller, st: TrajectoryStore, code: int) -> None:
    if st.playback is not None:
        _finished(ctl, st.playback.origin, 64, code)
    st.playback = None
    fire_mode(ctl, ModeEvent.PLAYBACK_END)
    st.finish(64, code)


def playback_step(ctl: Controller, dt: float) -> None:
    """One control period of mode 11."""
    st = store_of(ctl)
    pb = st.playback
    if pb is None:
        fire_mode(ctl, ModeEvent.PLAYBACK_END)
        return
    if ctl.motion_state not in (STATE_SLEEP, STATE_MOVING):
        _end_playback(ctl, st, 1)  # stopped (state 4) or reset: playback ends unfinished
        return
    if pb.lead_in is not None:
        pb.t += dt
        q, _, _ = pb.lead_in.at(pb.t)
        ctl.q = q
        if pb.t >= pb.lead_in.duration:
            pb.lead_in = None
        fire(ctl, Event.SERVO_MOVING)
        return
    n = len(pb.samples)
    pb.index += pb.factor * dt / st.loaded_period
    if pb.index >= n - 1:
        pb.done_times += 1
        if pb.times != -1 and pb.done_times >= pb.times:
            ctl.q = pb.samples[-1].copy()
            _end_playback(ctl, st, 0)
            fire(ctl, Event.SERVO_AT_TARGET)
            return
        # Next pass: back to the first point, then on.
        s = ctl.settings
        ctl.q = pb.samples[-1].copy()
        pb.index = 0.0
        pb.t = 0.0
        if float(np.max(np.abs(pb.samples[0] - ctl.q))) > 1e-9:
            pb.lead_in = motion.plan_joint_move(ctl.q, pb.samples[0], LEAD_IN_SPEED,
                                                min(LEAD_IN_ACC, s.joint_maxacc), s.joint_jerk)
        fire(ctl, Event.SERVO_MOVING)
        return
    i = int(np.floor(pb.index + 1e-9))
    u = pb.index - i
    q = pb.samples[i] if u < 1e-9 else pb.samples[i] + u * (pb.samples[i + 1] - pb.samples[i])
    ctl.q = np.asarray(q, dtype=float).copy()
    fire(ctl, Event.SERVO_MOVING)


def peak_speed(ctl: Controller, factor: int) -> tuple[int, float]:
    """Register 230: (joint 1-based, peak speed rad/s) of the loaded trajectory at ``factor``."""
    st = store_of(ctl)
    if st.loaded is None or len(st.loaded) < 2:
        return 0, 0.0
    v = np.abs(np.diff(st.loaded, axis=0)) / st.loaded_period * factor
    joint = int(np.argmax(np.max(v, axis=0)))
    return joint + 1, float(np.max(v))
