r"""The admin channel's commands (an emulator started with ``serve --admin``; no real control box has
them): ``inject`` a fault, ``clear`` them, ``set-input`` a sensor, ``step`` lockstep time and keep
``checkpoint``\ s. Each sends one request of :mod:`xarm_emu.protocol.admin` through :func:`.options.admin`."""

from __future__ import annotations

import inspect
import json
import math
from typing import Annotated, Any

import typer

from ..protocol.frame import COMMAND_PORT
from .options import AdminPortOpt, HostOpt, PortOpt, admin, console, err_console, user_error

inject_app = typer.Typer(no_args_is_help=True, help=(
    "Inject a fault into an emulator started with `xarm-emu serve --admin`. The emulator is addressed "
    "by --host and --port (its command port, as for `status`); the admin channel listens on loopback at "
    "the command port + 10000 (502 -> 10502) unless the server was given --admin-port, in which case pass "
    "the same --admin-port here."))

_CodeArg = typer.Argument
_JointOpt = Annotated[int, typer.Option(help="Joint number, 1..axis.")]

#: The ``inject`` commands, one per fault of the admin channel (protocol.admin.COMMANDS): name ->
#: (help, its own parameters as (name, annotation), and the admin request's key for each).
INJECT_COMMANDS: dict[str, tuple[str, tuple[tuple[str, Any, str], ...]]] = {
    "estop": ("Press the emergency stop (error C1).", ()),
    "error": ("Raise a control box error.", (
        ("code", Annotated[str, _CodeArg(help="Control box error, e.g. C31 (manual 3.2.1).")], "code"),)),
    "warning": ("Raise a control box warning.", (
        ("code", Annotated[str, _CodeArg(help="Warning code, e.g. 11 (manual 3.2.2).")], "code"),)),
    "servo-error": ("Raise a joint (servo) error on one joint (error C10 + joint).", (
        ("code", Annotated[str, _CodeArg(help="Servo error, e.g. S23 (manual 3.1).")], "code"),
        ("joint", _JointOpt, "joint"))),
    "gripper-error": ("Raise an error of the attached gripper.", (
        ("code", Annotated[str, _CodeArg(help="Gripper error: xArm gripper G11 (manual 3.3), Robotiq fault "
                                              "(gFLT) 14 or 0x0E, BIO gripper (G2 or G1) 11 or 12, Inspire "
                                              "hand an error byte 1..255.")], "code"),)),
    "track-error": ("Raise a linear track drive error (serve --linear-track).", (
        ("code", Annotated[str, _CodeArg(help="Drive error, e.g. 12 (speed overlimit).")], "code"),)),
    "end-module-lost": ("The end module stops answering (error C28).", ()),
    "collision": ("Push on a joint: error C31 when the collision sensitivity (register 37) detects the "
                  "torque.", (
                      ("joint", _JointOpt, "joint"),
                      ("torque", Annotated[float, typer.Option(help="External torque on that joint, N m.")],
                       "torque"))),
    "report-pause": ("Stop the report streams for a while (wall time).", (
        ("duration", Annotated[str, _CodeArg(help="e.g. 2s, 500ms.")], "seconds"),)),
    "reply-delay": ("Delay every command reply.", (
        ("duration", Annotated[str, _CodeArg(help="e.g. 50ms; 0 switches it off.")], "seconds"),)),
    "drop-clients": ("Close every command and report connection.", ()),
    "ft-error": ("The F/T sensor (serve --ft-sensor) reports an error, as get_ft_sensor_error reads it "
                 "(0 clears it).", (
                     ("code", Annotated[int, _CodeArg(help="Sensor error code, 1..255; 0 clears.")],
                      "code"),)),
}


def _inject_command(cmd: str, doc: str, own: tuple[tuple[str, Any, str], ...]) -> Any:
    """The ``inject <cmd>`` function: its own parameters, then --host, --port and --admin-port."""
    keys = {name: key for name, _, key in own}

    def command(**kw: Any) -> None:
        admin(kw.pop("host"), kw.pop("port"), kw.pop("admin_port"), cmd,
               **{keys[name]: value for name, value in kw.items()})

    kind = inspect.Parameter.KEYWORD_ONLY
    params = [inspect.Parameter(name, kind, annotation=ann) for name, ann, _ in own]
    params += [inspect.Parameter("host", kind, annotation=HostOpt, default="127.0.0.1"),
               inspect.Parameter("port", kind, annotation=PortOpt, default=COMMAND_PORT),
               inspect.Parameter("admin_port", kind, annotation=AdminPortOpt, default=None)]
    command.__signature__ = inspect.Signature(params, return_annotation=None)  # type: ignore[attr-defined]
    command.__annotations__ = {p.name: p.annotation for p in params} | {"return": None}
    command.__doc__ = doc
    command.__name__ = command.__qualname__ = "inject_" + cmd.replace("-", "_")
    return command


for _cmd, (_doc, _own) in INJECT_COMMANDS.items():
    inject_app.command(_cmd)(_inject_command(_cmd, _doc, _own))



def clear(host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT, admin_port: AdminPortOpt = None) -> None:
    """Clear every injected fault, the reply delay and the report pause (admin channel)."""
    admin(host, port, admin_port, "clear")


def set_input(
    kind: Annotated[str, typer.Argument(help="cgpio, tgpio, analog, tool-analog, vacuum-object (with "
                                             "serve --vacuum: 1 an object seals the cup, 0 none), "
                                             "gripper-object (with a Robotiq or BIO gripper: an "
                                             "object VALUE mm wide between "
                                             "the fingers, index 0, or around them, index 1; 0 removes "
                                             "it), or ft "
                                             "(with serve --ft-sensor: an external wrench on the TCP).")],
    values: Annotated[list[str], typer.Argument(help="INDEX VALUE (0/1 for digital inputs, volts for "
                                                     "analog ones), or for ft: FX FY FZ TX TY TZ (N, N m).")],
    frame: Annotated[str, typer.Option(help="ft: the wrench's frame, tool or base.")] = "tool",
    ramp: Annotated[float, typer.Option(help="ft: reach the wrench linearly over this many seconds.")] = 0.0,
    hold: Annotated[float | None, typer.Option("--for", help="ft: remove the wrench after this many "
                                                             "seconds (default: hold it).")] = None,
    host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT, admin_port: AdminPortOpt = None,
) -> None:
    """Play a sensor input: `set-input cgpio 3 1`, `set-input tgpio 0 1`, `set-input analog 1 5.0`,
    `set-input ft 0 0 -10 0 0 0 --frame base --ramp 0.5 --for 2`."""
    if kind == "ft":
        wrench = _finite_numbers(values, 6, "set-input ft: FX FY FZ TX TY TZ")
        for name, x in (("--ramp", ramp), ("--for", hold)):
            if x is not None and not (math.isfinite(x) and x >= 0):
                user_error(f"{name}: a finite number of seconds >= 0, got {x}")
        if frame not in ("tool", "base"):
            user_error(f"--frame: tool or base, got {frame!r}")
        args: dict[str, Any] = {"wrench": wrench, "frame": frame, "ramp": ramp}
        if hold is not None:
            args["for"] = hold
        admin(host, port, admin_port, "set-input", refused_exit=2, kind="ft", **args)
        return
    if len(values) != 2:
        user_error(f"set-input {kind}: INDEX VALUE, got {' '.join(values) or 'nothing'}")
    try:
        index, value = int(values[0]), float(values[1])
    except ValueError:
        user_error(f"set-input {kind}: INDEX is an integer and VALUE a number, got {' '.join(values)}")
    admin(host, port, admin_port, "set-input", kind=kind, index=index, value=value)


def _finite_numbers(values: list[str], n: int, what: str) -> list[float]:
    """``n`` finite numbers from the command line, else one line and exit 2."""
    if len(values) != n:
        user_error(f"{what}: {n} numbers, got {len(values)}")
    try:
        out = [float(v) for v in values]
    except ValueError:
        user_error(f"{what}: numbers, got {' '.join(values)}")
    if not all(math.isfinite(x) for x in out):
        user_error(f"{what}: finite numbers (no nan or inf), got {' '.join(values)}")
    return out


def step(
    duration: Annotated[str, typer.Argument(help="Controller time to run, e.g. 0.5s, 40ms.")],
    host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT, admin_port: AdminPortOpt = None,
) -> None:
    """Lockstep: run an emulator started with `serve --stepped --admin` for this much controller time."""
    admin(host, port, admin_port, "step", seconds=duration)


# -- checkpoints through the admin channel (an emulator feature; no real control box has it) -------
checkpoint_app = typer.Typer(no_args_is_help=True, help=(
    "Keep the whole state of an emulator started with `xarm-emu serve --admin` under a name, and go "
    "back to it (in the emulator's memory, until it exits). Addressed as for `xarm-emu inject`."))


NameArg = Annotated[str, typer.Argument(help="Checkpoint name, e.g. before-pick.")]


def _checkpoint_name(name: str) -> str:
    from ..protocol.admin import checkpoint_name

    try:
        return checkpoint_name(name)
    except ValueError as exc:
        err_console.print(str(exc))
        raise typer.Exit(2) from None


@checkpoint_app.command("save")
def checkpoint_save(name: NameArg, host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
                    admin_port: AdminPortOpt = None) -> None:
    """Keep the emulator's whole state (motion, faults, IO, settings) under NAME."""
    admin(host, port, admin_port, "checkpoint-save", refused_exit=2, name=_checkpoint_name(name))


@checkpoint_app.command("restore")
def checkpoint_restore(name: NameArg, host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
                       admin_port: AdminPortOpt = None) -> None:
    """Put the emulator back to the state saved under NAME."""
    admin(host, port, admin_port, "checkpoint-restore", refused_exit=2, name=_checkpoint_name(name))


@checkpoint_app.command("list")
def checkpoint_list(host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
                    admin_port: AdminPortOpt = None) -> None:
    """Print the saved checkpoint names, one per line."""
    names = json.loads(admin(host, port, admin_port, "checkpoint-list", refused_exit=2))
    for name in names:
        console.print(name, markup=False, highlight=False)


