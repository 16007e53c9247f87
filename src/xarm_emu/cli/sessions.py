"""Sessions of a control box: ``record`` its reports to a Rerun recording, ``plot`` a recording or a
command trace, ``replay`` a command trace into a fresh emulator and compare the replies."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from ..model.robots import get_model
from ..protocol.firmware import VersionError, profile_for
from ..protocol.frame import COMMAND_PORT
from ..protocol.reports import DEVELOP_PORT, RICH_PORT
from .options import check_port, console, err_console, user_error


def record_session(
    out: Annotated[Path, typer.Argument(help="Rerun recording to write, e.g. session.rrd.")],
    host: Annotated[str, typer.Option(help="Control box address (real or emulated).")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Command port, asked for the arm's model.")] = COMMAND_PORT,
    develop_port: Annotated[int, typer.Option(help="Develop report port (100 Hz).")] = DEVELOP_PORT,
    rich_port: Annotated[int, typer.Option(help="Rich report port (5 Hz).")] = RICH_PORT,
    duration: Annotated[float | None, typer.Option(help="Seconds to record (default: until Ctrl-C or "
                                                        "the box closes its reports).")] = None,
) -> None:
    """Record a control box's reports (joints, TCP, torques, state, errors, IO) and the arm's geometry
    to a Rerun recording; open it with `rerun FILE` (native) or `rerun --web-viewer FILE`."""
    from ..client import Client, ClientError
    from ..record import RecordError, SessionRecorder, model_of, record_reports

    for name, value in (("--port", port), ("--develop-port", develop_port), ("--rich-port", rich_port)):
        check_port(name, value)
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        user_error("--duration must be a positive number of seconds")
    try:
        with Client(host, port, timeout=3.0) as c:
            version = c.get_version()
    except (OSError, ClientError) as exc:
        err_console.print(f"cannot reach the control box at {host}:{port}: {exc}")
        raise typer.Exit(1) from None
    try:
        recorder = SessionRecorder(out, model_of(version))
    except RecordError as exc:
        user_error(str(exc))
    recorder.event(f"recording {host}: {version}")
    console.print(f"recording {host} ({version}) to {out}; Ctrl-C ends it", soft_wrap=True)
    try:
        frames = record_reports(recorder, host, develop_port, rich_port, duration=duration)
    except OSError as exc:
        err_console.print(f"cannot read the reports of {host}: {exc}")
        raise typer.Exit(1) from None
    except KeyboardInterrupt:
        frames = recorder.reports
    finally:
        recorder.close()
    console.print(f"{frames} report frames in {out}; open it with: rerun {out}", soft_wrap=True)


def plot_session(
    source: Annotated[Path, typer.Argument(help="A Rerun recording (.rrd, xarm-emu record) or a command "
                                                "trace (serve --trace).")],
    out: Annotated[Path, typer.Option("-o", "--output", help="PNG to write.")] = Path("run.png"),
    dof: Annotated[int | None, typer.Option(help="Joints to draw (default: all recorded).")] = None,
) -> None:
    """Draw joints, TCP path and speed, torques and events against time to a PNG."""
    from ..plot import PlotError, plot, read

    if not source.exists():
        user_error(f"no such file: {source}")
    try:
        plot(read(source), out, title=source.name, dof=dof)
    except PlotError as exc:
        user_error(str(exc))
    console.print(f"wrote {out}", soft_wrap=True)


def replay_trace(
    trace_file: Annotated[Path, typer.Argument(help="A command trace of `serve --trace`.")],
    model: Annotated[str | None, typer.Option(help="Arm model the trace was recorded with (default: "
                                                   "as the trace says, else 6).")] = None,
    firmware: Annotated[str | None, typer.Option(help="Firmware version of the recorded box (default: as "
                                                      "the trace says, else the version its register 1 "
                                                      "reply claimed, else serve's default).")] = None,
    vacuum: Annotated[bool, typer.Option("--vacuum", help="The box had a vacuum gripper (default: as the "
                                                          "trace says).")] = False,
    tolerance: Annotated[float, typer.Option(help="Largest difference of a decoded value that still "
                                                  "counts as the same.")] = 1e-6,
    all_differences: Annotated[bool, typer.Option("--all", help="List every differing reply, not only "
                                                               "the first.")] = False,
) -> None:
    """Send a recorded command trace into a fresh emulator in stepped time and compare the replies.

    Exit status 0 when every reply is the same, 1 at the first difference (printed), 2 for a bad
    trace or option."""
    from ..replay import ReplayError, replay

    try:
        robot = get_model(model) if model is not None else None
        if firmware is not None:
            from ..controller.emulator import check_firmware

            profile = profile_for(firmware)
            if robot is not None:
                check_firmware(robot, profile)
    except (ValueError, VersionError) as exc:
        user_error(f"--model/--firmware: {exc}")
    try:
        result = replay(trace_file, model=model, firmware=firmware, vacuum=True if vacuum else None,
                        tolerance=tolerance, stop_at_first=not all_differences)
    except ReplayError as exc:
        user_error(str(exc))
    done = f"{result.requests} requests replayed"
    if result.outside:
        done += f" with {result.outside} changes from outside the protocol (faults, inputs)"
    if not result.differences:
        console.print(f"{done}: every reply is the same", soft_wrap=True)
        return
    first = result.differences[0].describe()
    console.print(f"{done}; first difference: {first}", soft_wrap=True)
    for diff in result.differences[1:]:
        console.print(f"  {diff.describe()}", soft_wrap=True)
    raise typer.Exit(1)
