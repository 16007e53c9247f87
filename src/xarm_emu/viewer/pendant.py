"""The pendant: viser's GUI panel beside the 3D view, a teach pendant for the emulated box.

- **Status**: model and firmware, state (register 13), mode (register 19), error and warning
  (register 15) with the manual's handling text (sections 3.2.1 and 3.2.2), cmdnum (register 14),
  joints, TCP pose, gripper and IO, all from the report snapshot (section 2.1.6).
- **Actions**: every button sends the register a client would send (enable 11, state 12, clear
  16/17, mode 19, joint move 23, linear move 21, tool move 28, home 25) through
  :meth:`Pendant.command`, so its effect is what the protocol answers. The admin actions (faults,
  inputs, step or speed) are shown only when the server has ``--admin``; faults, inputs and step go
  through the admin channel's own request preparation (:func:`xarm_emu.server.admin.prepare`).
- **Plot**: the last :data:`PLOT_SECONDS` of joints, TCP speed and joint torques.

Button callbacks run in viser's threads; each action is carried out in the server's event loop
(:meth:`Pendant.run`), after the control periods that are due, exactly like a command frame.
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from ..protocol import codes
from ..protocol.frame import STATE_ERROR, STATE_WARNING
from ..protocol.registers import REGISTERS
from ..server import admin
from ..server.core import EmulatorServer

log = logging.getLogger(__name__)

PLOT_SECONDS = 10.0
PLOT_RATE = 10.0  # samples per second
#: The status panel's last line: a page that shows it has its panel drawn (what tests wait for).
READY = "Pendant ready"
#: Motion states of register 13 (manual 2.2, "Get the motion state").
STATES = {1: "1 moving", 2: "2 sleeping (ready)", 3: "3 suspended", 4: "4 stopped", 5: "5 system reset"}
#: Motion modes of register 19.
MODES = {0: "0 position", 1: "1 servo", 2: "2 joint teaching", 3: "3 cartesian teaching"}
#: States register 12 sets: 0 enters motion, 3 suspends, 4 stops.
SET_STATES = ("0 ready", "3 suspend", "4 stop")
JOG_SPEED = 0.35  # rad/s, joint jog
JOG_ACC = 5.0  # rad/s^2
LINE_SPEED = 50.0  # mm/s, TCP jog
LINE_ACC = 500.0  # mm/s^2
AXES = ("X", "Y", "Z", "Roll", "Pitch", "Yaw")


def describe_state(snap: Any) -> dict[str, str]:
    """The status panel's fields, from a report snapshot (section 2.1.6): name -> text."""
    dof = int(snap.axis)
    joints = ", ".join(_fmt(math.degrees(q), 2) for q in list(snap.joints)[:dof])
    p = list(snap.pose)
    pose = (", ".join(_fmt(v, 1) for v in p[:3]) + " mm; "
            + ", ".join(_fmt(math.degrees(v), 2) for v in p[3:6]) + " deg")
    return {
        "state": STATES.get(int(snap.state), str(snap.state)),
        "mode": MODES.get(int(snap.mode), str(snap.mode)),
        "error": codes.describe_error(int(snap.error)),
        "warning": codes.describe_warning(int(snap.warning)),
        "cmdnum": str(int(snap.cmdnum)),
        "joints": f"{joints} deg",
        "pose": pose,
        "enabled": "all joints" if snap.enable_bits == (1 << dof) - 1 else f"bits {snap.enable_bits:#04x}",
        "cgpio": f"in {snap.cgpio_input_config:#06x}, out {snap.cgpio_output_config:#06x}",
        "analog": "AI " + ", ".join(f"{v:.2f}" for v in snap.analog_inputs) + " V; AO "
                  + ", ".join(f"{v:.2f}" for v in snap.analog_outputs) + " V",
    }


class Pendant:
    """The GUI panel of one :class:`~xarm_emu.server.core.EmulatorServer` on a viser server."""

    def __init__(self, gui: Any, server: EmulatorServer) -> None:
        self.gui = gui
        self.server = server
        self.emulator = server.emulator
        self.loop: asyncio.AbstractEventLoop | None = None
        self.last_message = ""
        self._status_text = ""
        n = max(2, int(PLOT_SECONDS * PLOT_RATE))
        self._samples: deque[tuple[float, list[float], float, list[float]]] = deque(maxlen=n)
        self._last_sample = -math.inf
        self._build()

    # -- running an action in the server's loop -------------------------------------------------
    def run(self, action: Callable[[], str], timeout: float = 5.0) -> str:
        """Carry out ``action`` in the server's event loop and return its message (shown in the panel).

        Called from viser's threads; in the loop thread itself (tests) it runs at once."""
        loop = self.loop

        def now() -> str:
            with self.server.lock:  # the arm's lock, as a command takes it
                self.server.catch_up()  # the control periods due first, as before a command frame
                return action()

        async def inside() -> str:
            return now()

        try:
            running = asyncio.get_running_loop()
        except RuntimeError:
            running = None
        try:
            if loop is None or running is loop:
                msg = now()
            else:
                msg = asyncio.run_coroutine_threadsafe(inside(), loop).result(timeout)
        except (ValueError, RuntimeError, TimeoutError) as exc:  # AdminError is a ValueError
            msg = f"refused: {exc}"
        except Exception as exc:  # noqa: BLE001 - a button must answer, not end viser's thread
            log.exception("pendant action failed")
            msg = f"failed: {exc}"
        self.last_message = msg
        self._message.content = f"**Last action:** {msg}"
        return msg

    def _send(self, code: int, values: dict[str, Any]) -> int:
        """Register ``code`` with ``values`` answered as a command connection's request (in the
        server's loop, under the arm's lock): in the command trace too, with peer "pendant", so
        ``xarm-emu replay`` sends it again. Returns the reply's state byte."""
        frame = self.server.answer(0, 2, code, REGISTERS[code].request.encode(values), peer="pendant")
        return frame[7]

    def command(self, code: int, **values: Any) -> str:
        """Send register ``code`` with ``values`` to the emulator as a client would (section 2.1.2);
        returns what the reply's state byte says."""
        reg = REGISTERS[code]

        def send() -> str:
            return f"{reg.name} ({code}): " + _verdict(self._send(code, values))

        return self.run(send)

    def admin(self, request: dict[str, Any]) -> str:
        """One admin-channel request (``--admin`` only), checked and carried out as the channel does."""
        if not self.server.config.admin:
            return self.run(lambda: "refused: the admin actions need serve --admin")

        def act() -> str:
            return admin.prepare(self.server, request)()

        return self.run(act)

    # -- the panel ------------------------------------------------------------------------------
    def _build(self) -> None:
        gui = self.gui
        emu = self.emulator
        gui.configure_theme(control_width="large")
        with gui.add_folder("Status", order=0):
            self._title = gui.add_markdown(f"**{emu.model.name}**, firmware {emu.firmware.version}")
            self._status = gui.add_markdown("")
            self._message = gui.add_markdown("**Last action:** none")
        with gui.add_folder("Actions", order=1):
            gui.add_button("Enable", hint="Register 11 (all joints on), then register 12 state 0").on_click(
                lambda _: self.enable())
            gui.add_button("Disable", hint="Register 11, all joints off").on_click(
                lambda _: self.command(11, joint=8, enable=0))
            gui.add_button("Clear error", hint="Register 16").on_click(lambda _: self.command(16))
            gui.add_button("Clear warning", hint="Register 17").on_click(lambda _: self.command(17))
            stop = gui.add_button("Stop", color="red", hint="Register 12 state 4 (the SDK's stop)")
            stop.on_click(lambda _: self.command(12, state=4))
            state = gui.add_dropdown("State", SET_STATES)
            gui.add_button("Set state", hint="Register 12").on_click(
                lambda _: self.command(12, state=int(state.value.split()[0])))
            mode = gui.add_dropdown("Mode", tuple(MODES.values()))
            gui.add_button("Set mode", hint="Register 19").on_click(
                lambda _: self.command(19, mode=int(mode.value.split()[0])))
            gui.add_button("Go home", hint="Register 25").on_click(
                lambda _: self.command(25, speed=JOG_SPEED, acc=JOG_ACC, mvtime=0.0))
            home = emu.model.zero_pose
            self._target_xyz = gui.add_vector3("Target (mm)", (home[0], home[1], home[2]), step=1.0)
            self._target_rpy = gui.add_vector3("Target (deg)", tuple(math.degrees(v) for v in home[3:6]),
                                               step=0.1)
            gui.add_button("Move to pose", hint="Register 21, base frame").on_click(
                lambda _: self.move_to_pose(self._target_xyz.value, self._target_rpy.value))
        with gui.add_folder("Jog joints", order=2):
            self._joint_step = gui.add_number("Step (deg)", 5.0, min=0.1, max=90.0, step=0.1)
            for j in range(emu.model.dof):
                group = gui.add_button_group(f"J{j + 1}", (f"J{j + 1} -", f"J{j + 1} +"))
                group.on_click(lambda ev, j=j: self.jog_joint(j, 1 if ev.target.value.endswith("+") else -1))
        with gui.add_folder("Jog TCP", order=3):
            self._frame = gui.add_dropdown("Frame", ("base", "tool"))
            self._line_step = gui.add_number("Step (mm or deg)", 10.0, min=0.1, max=200.0, step=0.1)
            for a, name in enumerate(AXES):
                group = gui.add_button_group(name, (f"{name} -", f"{name} +"))
                group.on_click(lambda ev, a=a: self.jog_tcp(a, 1 if ev.target.value.endswith("+") else -1))
        with gui.add_folder("Plot", order=4, expand_by_default=False):
            z = np.zeros(2)
            dof = emu.model.dof
            self._plot_joints = gui.add_uplot(
                (z,) + (z,) * dof, ({"label": "t (s)"},) + tuple(
                    {"label": f"J{j + 1} (deg)", "stroke": _COLORS[j % len(_COLORS)]} for j in range(dof)),
                title="Joints", aspect=1.6, scales=_SECONDS)
            self._plot_speed = gui.add_uplot((z, z), ({"label": "t (s)"}, {"label": "TCP speed (mm/s)",
                                                                            "stroke": _COLORS[0]}),
                                             title="TCP speed", aspect=2.0, scales=_SECONDS)
            self._plot_torque = gui.add_uplot(
                (z,) + (z,) * dof, ({"label": "t (s)"},) + tuple(
                    {"label": f"J{j + 1} (N m)", "stroke": _COLORS[j % len(_COLORS)]} for j in range(dof)),
                title="Torques", aspect=1.6, scales=_SECONDS)
        if self.server.config.admin:
            self._build_admin()

    def _build_admin(self) -> None:
        gui = self.gui
        with gui.add_folder("Admin (--admin)", order=5):
            gui.add_markdown("Fault injection and inputs: no real control box has these.")
            code = gui.add_text("Error code", "C35")
            gui.add_button("Inject error").on_click(
                lambda _: self.admin({"cmd": "error", "code": code.value}))
            warn = gui.add_text("Warning code", "W11")
            gui.add_button("Inject warning").on_click(
                lambda _: self.admin({"cmd": "warning", "code": warn.value}))
            gui.add_button("E-stop button (C1)", color="red").on_click(lambda _: self.admin({"cmd": "estop"}))
            joint = gui.add_number("Collision joint", 1, min=1, max=self.emulator.model.dof, step=1)
            torque = gui.add_number("Collision torque (N m)", 30.0, step=0.5)
            gui.add_button("Push (collision)").on_click(lambda _: self.admin(
                {"cmd": "collision", "joint": int(joint.value), "torque": float(torque.value)}))
            gui.add_button("Clear faults").on_click(lambda _: self.admin({"cmd": "clear"}))
            kind = gui.add_dropdown("Input", ("cgpio", "tgpio", "analog", "tool-analog", "vacuum-object"))
            index = gui.add_number("Input index", 0, min=0, max=15, step=1)
            value = gui.add_number("Input value", 1.0, step=0.1)
            gui.add_button("Play input").on_click(lambda _: self.admin(
                {"cmd": "set-input", "kind": kind.value, "index": int(index.value),
                 "value": float(value.value)}))
            if self.server.config.stepped:
                secs = gui.add_number("Step (s)", 0.1, min=0.004, max=60.0, step=0.004)
                gui.add_button("Step time").on_click(
                    lambda _: self.admin({"cmd": "step", "seconds": float(secs.value)}))
            else:
                speed = gui.add_number("Speed (x real time)", self.server.config.speed, min=0.01, max=100.0,
                                       step=0.01)
                gui.add_button("Set speed").on_click(lambda _: self.set_speed(float(speed.value)))

    def set_speed(self, speed: float) -> str:
        """Scale time from now on (``serve --speed``): the periods due so far run at the old speed."""
        if not self.server.config.admin:
            return self.run(lambda: "refused: the admin actions need serve --admin")
        if self.server.config.stepped:
            return self.run(lambda: "refused: lockstep time advances only by step")
        if not (math.isfinite(speed) and speed > 0.0):
            return self.run(lambda: f"refused: speed must be a positive number, got {speed!r}")

        def scale() -> str:
            clock = self.server.clock
            clock.speed = speed
            clock.start(asyncio.get_running_loop().time())
            return f"speed x{speed:g}"

        return self.run(scale)

    # -- the actions ----------------------------------------------------------------------------
    def enable(self) -> str:
        """Enable all joints (register 11) and enter the ready state (register 12 state 0)."""
        first = self.command(11, joint=8, enable=1)
        return first + "; " + self.command(12, state=0)

    def move_to_pose(self, xyz: tuple[float, float, float], rpy_deg: tuple[float, float, float]) -> str:
        """Linear move (register 21) to ``xyz`` (mm) and roll, pitch, yaw ``rpy_deg`` in the base frame."""
        pose = tuple(float(v) for v in xyz) + tuple(math.radians(float(v)) for v in rpy_deg)
        return self.command(21, pose=pose, speed=LINE_SPEED, acc=LINE_ACC, mvtime=0.0)

    def jog_joint(self, joint: int, sign: int) -> str:
        """Move joint ``joint`` (0-based) by the step (register 23, from the current joints)."""
        step = math.radians(float(self._joint_step.value)) * sign
        q = [0.0] * 7

        def target() -> str:
            cur = list(self.emulator.snapshot().joints)
            q[: len(cur)] = cur[:7]
            q[joint] += step
            state = self._send(23, {"joints": tuple(q), "speed": JOG_SPEED, "acc": JOG_ACC, "mvtime": 0.0})
            return f"MOVE_JOINT (23) J{joint + 1} {math.degrees(step):+g} deg: " + _verdict(state)

        return self.run(target)

    def jog_tcp(self, axis: int, sign: int) -> str:
        """Move the TCP along or about ``axis`` (0..5: x, y, z, roll, pitch, yaw) by the step: register
        21 to the current pose plus the step in the base frame, register 28 by the step in the tool frame."""
        step = float(self._line_step.value) * sign
        delta = [0.0] * 6
        delta[axis] = step if axis < 3 else math.radians(step)
        tool = self._frame.value == "tool"

        def move() -> str:
            if tool:
                code, pose = 28, delta
            else:
                cur = list(self.emulator.snapshot().pose)
                code, pose = 21, [c + d for c, d in zip(cur, delta, strict=True)]
            reg = REGISTERS[code]
            state = self._send(code, {"pose": tuple(pose), "speed": LINE_SPEED, "acc": LINE_ACC,
                                      "mvtime": 0.0})
            return f"{reg.name} ({code}) {AXES[axis]} {step:+g}: " + _verdict(state)

        return self.run(move)

    # -- updates (in the server's loop) ---------------------------------------------------------
    def update(self) -> None:
        """Refresh the status panel and the plot from the report snapshot."""
        snap = self.emulator.snapshot()
        fields = describe_state(snap)
        g = self.emulator.gripper.gripper
        info = self.emulator.gripper_status()
        if info["gripper"] == "xarm":
            fields["gripper"] = (f"{'enabled' if g.enabled else 'off'}, position {g.position:.0f}"
                                 + (f", error G{g.error}" if g.error else ""))
        else:
            fields["gripper"] = (f"{info['gripper']}, opening {info['opening_mm']:g} mm"
                                 + (", holding an object" if info["object"] else "")
                                 + (f", error {info['error']}" if info["error"] else ""))
        text = "\n\n".join(f"**{k.capitalize()}:** {v}" for k, v in fields.items())
        text += f"\n\n*{READY}: the status above is the box's own, refreshed as it changes.*"
        if text != self._status_text:
            self._status_text = text
            self._status.content = text
        t = self.emulator.time
        if t < self._last_sample:  # restored to an earlier checkpoint
            self._samples.clear()
        if t - self._last_sample >= 1.0 / PLOT_RATE:
            self._last_sample = t
            dof = self.emulator.model.dof
            joints = [math.degrees(q) for q in list(snap.joints)[:dof]]
            torques = [float(v) for v in list(snap.torques)[:dof]]
            self._samples.append((t, joints, float(snap.tcp_speed), torques))
            self._redraw_plot()

    def _redraw_plot(self) -> None:
        if len(self._samples) < 2:
            return
        ts = np.array([s[0] for s in self._samples])
        joints = np.array([s[1] for s in self._samples]).T
        torques = np.array([s[3] for s in self._samples]).T
        self._plot_joints.data = (ts, *joints)
        self._plot_speed.data = (ts, np.array([s[2] for s in self._samples]))
        self._plot_torque.data = (ts, *torques)

    @property
    def samples(self) -> list[tuple[float, list[float], float, list[float]]]:
        """The plotted samples: (time s, joints deg, TCP speed mm/s, torques N m)."""
        return list(self._samples)


#: The plots' x axis is controller time in seconds, not a date.
_SECONDS: dict[str, Any] = {"x": {"time": False}}
_COLORS = ("#e6194b", "#3cb44b", "#4363d8", "#f58231", "#911eb4", "#42d4f4", "#f032e6")


def _fmt(value: float, digits: int) -> str:
    """``value`` with ``digits`` decimals, never "-0.00"."""
    return f"{round(float(value), digits) + 0.0:.{digits}f}"


def _verdict(state: int) -> str:
    flags = [name for bit, name in ((STATE_ERROR, "error"), (STATE_WARNING, "warning")) if state & bit]
    return "ok" if not flags else "reply state " + " and ".join(flags)
