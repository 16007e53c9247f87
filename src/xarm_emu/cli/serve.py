"""``serve``: run the emulator with its command port and report ports, and every option that says
which box it is (model, firmware, end tool, bus devices), where it listens and what it records.

Every option is checked before any port opens (exit 2, one line); :mod:`.serving` then starts the
servers and :mod:`.fleet` serves a fleet file's arms.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer
from typer.core import TyperCommand

from ..model.calibration import CalibrationError
from ..model.calibration import load as load_calibration
from ..model.robots import MODEL_NAMES, RobotModel, get_model, with_calibration
from ..protocol.admin_token import default_config_dir
from ..protocol.firmware import SERVE_VERSION, SUPPORTED_VERSIONS, FirmwareProfile, VersionError, profile_for
from ..protocol.frame import COMMAND_PORT
from ..protocol.reports import DEVELOP_PORT, NORMAL_PORT, RICH_PORT
from ..server.report_sender import DEFAULT_PRIORITY as DEFAULT_REPORT_PRIORITY
from .fleet import check_workers, refuse_per_arm_flags, serve_fleet_workers
from .options import check_host, check_port, err_console, user_error
from .serving import start

_LOG_LEVELS = ("CRITICAL", "ERROR", "WARNING", "INFO", "DEBUG")


class ServeCommand(TyperCommand):
    """``serve``, whose ``--linear-track`` may be given bare (the default stroke)."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        return super().parse_args(ctx, bare_linear_track(args))


def bare_linear_track(args: list[str]) -> list[str]:
    """``--linear-track`` without a length (last, or before another option) as the default stroke."""
    from ..controller.devices.linear_track import DEFAULT_LENGTH

    out = list(args)
    for i, a in enumerate(out):
        if a == "--linear-track" and (i + 1 == len(out) or out[i + 1].startswith("-")):
            out[i] = f"--linear-track={DEFAULT_LENGTH}"
    return out


ModelOpt = Annotated[str, typer.Option(help="Arm model: " + ", ".join(MODEL_NAMES)
                                       + " (xArm 5/6/7, Lite 6, UFACTORY 850, xArm 7T).")]
BindHostOpt = Annotated[str, typer.Option(help="Address to bind (loopback by default).")]
CommandPortOpt = Annotated[int, typer.Option(help="Command port.")]
NormalPortOpt = Annotated[int, typer.Option(help="Normal report port (5 Hz).")]
RichPortOpt = Annotated[int, typer.Option(help="Rich report port (5 Hz).")]
DevelopPortOpt = Annotated[int, typer.Option(help="Develop report port (100 Hz).")]
ConfigDirOpt = Annotated[Path | None, typer.Option(help="Directory of saved configurations "
                                                        "(default: per-user config directory).")]
SpeedOpt = Annotated[float, typer.Option(help="Time scale: 10 runs ten times faster than real time.")]
LogLevelOpt = Annotated[str, typer.Option(help="Logging level.")]
AdminOpt = Annotated[bool, typer.Option("--admin", help="Open the fault-injection admin channel "
                                                         "(loopback only; see `xarm-emu inject`).")]
ServeAdminPortOpt = Annotated[int | None, typer.Option(help="Admin channel port (default: command port "
                                                       "+ 10000, e.g. 10502).")]
ViewOpt = Annotated[bool, typer.Option("--view", help="Serve the 3D view in the browser (needs the "
                                                       "'view' extra: viser).")]
ViewHostOpt = Annotated[str | None, typer.Option(help="Address of the 3D view (default: --host).")]
ViewPortOpt = Annotated[int, typer.Option(help="Port of the 3D view.")]
SteppedOpt = Annotated[bool, typer.Option("--stepped", help="Lockstep time: the controller advances only "
                                                            "by `xarm-emu step` (needs --admin).")]
LoopOpt = Annotated[str, typer.Option(help="Event loop: asyncio (default: the steadiest 100 Hz report in "
                                           "`make bench`) or uvloop.")]
FirmwareOpt = Annotated[str, typer.Option(help="Firmware version the box claims and behaves as: "
                                               + ", ".join(SUPPORTED_VERSIONS) + ".")]
VacuumOpt = Annotated[bool, typer.Option("--vacuum", help="Attach the xArm Vacuum Gripper: its pressure "
                                                           "switch answers on tool input 0.")]
LinearTrackOpt = Annotated[int | None, typer.Option(
    "--linear-track", metavar="[LENGTH_MM]",
    help="Attach a UFACTORY linear track on the control box RS-485: its stroke, 700, 1000 or "
         "1500 mm (bare: 700).")]
FtSensorOpt = Annotated[bool, typer.Option("--ft-sensor", help="Mount the six-axis F/T sensor between "
                                                                "flange and tool.")]
SceneOpt = Annotated[Path | None, typer.Option(help="Contact scene: planes and boxes the TCP presses "
                                                    "into, a TOML file "
                                                    "(controller/scene/contact.py).")]
GripperOpt = Annotated[str | None, typer.Option(help="The gripper on the tool RS-485: xarm (the default), "
                                                     "robotiq-2f85, robotiq-2f140, bio, bio-g1 "
                                                     "(the first-generation BIO) or inspire-rh56 (the "
                                                     "Inspire RH56 hand).")]
TraceOpt = Annotated[Path | None, typer.Option(help="Append every command-port request and reply to "
                                                    "this JSON-lines file (see server/trace.py).")]
FaultsOpt = Annotated[Path | None, typer.Option(help="Inject the faults and inputs this TOML schedule "
                                                     "lists at their controller times (server/faults.py).")
                      ]
FleetOpt = Annotated[Path | None, typer.Option(help="Serve the arms a TOML fleet file lists, in worker "
                                                    "processes (see src/xarm_emu/server/fleet.py); the "
                                                    "per-arm options above then come from the file.")]
WorkersOpt = Annotated[int | None, typer.Option(help="With --fleet: worker processes sharing the arms "
                                                     "(default: one per available CPU; 0: every arm in "
                                                     "this process, the default with --view). A worker "
                                                     "that dies is restarted with its arms.")]
RecordOpt = Annotated[Path | None, typer.Option(help="Record the session (reports, commands, errors, the "
                                                     "arm's geometry) to this Rerun .rrd file; open it "
                                                     "with `rerun FILE` (needs the 'record' extra).")
                      ]
LogJsonOpt = Annotated[bool, typer.Option("--log-json", help="Log one JSON object per line (time, "
                                                             "level, logger, message).")]
MaxConnectionsOpt = Annotated[int, typer.Option(help="Connections accepted per port (command and each "
                                                     "report port); beyond it new ones are closed at once. "
                                                     "0: the open-file limit (raised to its hard limit "
                                                     "at start) less 64, divided by 4 ports, at most "
                                                     "1000 (1000 from a hard limit of 4064 up).",
                                                min=0)]
FrameTimeoutOpt = Annotated[float, typer.Option(help="Close a command connection whose first or partial "
                                                     "frame is older than this (seconds; 0: never).",
                                                min=0.0)]
BacklogOpt = Annotated[int, typer.Option(help="Listen backlog of every port (bursts of connects).",
                                         min=1)]
LogFileOpt = Annotated[Path | None, typer.Option(help="Write the log to this file instead of stderr.")
                       ]
LogMaxBytesOpt = Annotated[int, typer.Option(help="Rotate --log-file at this size, keeping 3 old "
                                                  "files (0: never).", min=0)]
TraceMaxBytesOpt = Annotated[int, typer.Option(help="Rotate --trace to FILE.1 at this size (0: never).",
                                               min=0)]
ModbusPortOpt = Annotated[int | None, typer.Option(help="Also serve the standard Modbus-TCP map "
                                                        "(protocol 0) on this port, for PLC and SCADA "
                                                        "tools that cannot share the command port.")
                          ]
StudioOpt = Annotated[bool, typer.Option("--studio", help="Answer the SDK's xArm Studio HTTP calls "
                                                           "(initial point, mount, trajectories).")]
StudioPortOpt = Annotated[int, typer.Option(help="Port of --studio (the SDK uses 18333).")]
CalibrationOpt = Annotated[Path | None, typer.Option(help="Replace the emulator's estimated constants "
                                                          "with this calibration file (xarm-emu calibrate).")
                           ]
ReportPriorityOpt = Annotated[int | None, typer.Option(
    help="Real-time (SCHED_FIFO) priority 1-99 of the thread that sends the report frames (Linux, "
         "needs the privilege; a refusal is a warning); 0: normal scheduling. Default: priority "
         f"{DEFAULT_REPORT_PRIORITY} where the system allows it, else normal scheduling.",
    min=0, max=99, show_default=False)]


def serve(
    model: ModelOpt = "6", host: BindHostOpt = "127.0.0.1", port: CommandPortOpt = COMMAND_PORT,
    normal_port: NormalPortOpt = NORMAL_PORT, rich_port: RichPortOpt = RICH_PORT,
    develop_port: DevelopPortOpt = DEVELOP_PORT, config_dir: ConfigDirOpt = None, speed: SpeedOpt = 1.0,
    log_level: LogLevelOpt = "INFO", admin: AdminOpt = False, admin_port: ServeAdminPortOpt = None,
    view: ViewOpt = False, view_host: ViewHostOpt = None, view_port: ViewPortOpt = 8080,
    stepped: SteppedOpt = False, loop: LoopOpt = "asyncio", firmware: FirmwareOpt = SERVE_VERSION,
    vacuum: VacuumOpt = False, linear_track: LinearTrackOpt = None, ft_sensor: FtSensorOpt = False,
    scene: SceneOpt = None, gripper: GripperOpt = None, trace: TraceOpt = None, faults: FaultsOpt = None,
    fleet: FleetOpt = None, workers: WorkersOpt = None, record: RecordOpt = None,
    log_json: LogJsonOpt = False, max_connections: MaxConnectionsOpt = 0,
    frame_timeout: FrameTimeoutOpt = 60.0, backlog: BacklogOpt = 4096, log_file: LogFileOpt = None,
    log_max_bytes: LogMaxBytesOpt = 0, trace_max_bytes: TraceMaxBytesOpt = 0,
    modbus_port: ModbusPortOpt = None, studio: StudioOpt = False, studio_port: StudioPortOpt = 18333,
    calibration: CalibrationOpt = None, report_priority: ReportPriorityOpt = None,
) -> None:
    """Run the emulator with its command port and report ports.

    A serving process sets interpreter-wide settings for its report sender that a library user's
    process never gets: a 0.2 ms switch interval and frozen start-up objects (see
    ``report_sender.tune_process``), and real-time priority for the sender where allowed
    (``--report-priority``)."""
    from ..server.app import ServerConfig
    from ..server.fairness import Limits, raise_file_limit
    from ..server.logs import configure
    from ..server.report_sender import tune_process

    check_serve_options(log_level, host, (view_host or host) if view else None, {
        "--port": port, "--normal-port": normal_port, "--rich-port": rich_port,
        "--develop-port": develop_port, "--admin-port": admin_port, "--view-port": view_port,
        "--modbus-port": modbus_port, "--studio-port": studio_port if studio else None})
    configure(log_level, log_file, log_max_bytes, json_lines=log_json)
    raise_file_limit()
    check_run_options(record, fleet, loop, speed)
    cdir = config_dir if config_dir is not None else default_config_dir()
    cfg = ServerConfig(host=host, port=port, normal_port=normal_port, rich_port=rich_port,
                       develop_port=develop_port, speed=speed, admin=admin, admin_port=admin_port,
                       view=view, view_host=view_host or host, view_port=view_port, stepped=stepped,
                       trace=trace, faults=faults)
    cfg.limits = Limits(max_connections=max_connections, frame_timeout=frame_timeout, backlog=backlog)
    cfg.trace_max_bytes, cfg.report_priority = trace_max_bytes, report_priority
    tune_process()  # a process that only serves arms: the report sender's interpreter settings
    profile, robot = checked_arm(model, firmware, calibration, linear_track, gripper, vacuum, ft_sensor)
    if fleet is not None:
        refuse_per_arm_flags(cfg, robot is not get_model(6), vacuum or gripper is not None,
                             firmware != SERVE_VERSION,
                             linear_track is not None, ft_sensor=ft_sensor, scene=scene is not None)
    n_workers = check_workers(workers, fleet, view, record, modbus_port, studio)
    if fleet is not None and n_workers > 0:
        serve_fleet_workers(fleet, cfg, cdir, n_workers, (log_level.upper(), log_file, log_json),
                            loop == "uvloop")
        return
    start(cfg, fleet, robot, vacuum, cdir, profile, linear_track, loop, ft_sensor=ft_sensor, scene=scene,
          gripper=gripper, record=record, modbus_port=modbus_port,
          studio_port=studio_port if studio else None)


def check_serve_options(log_level: str, host: str, view_host: str | None,
                        ports: dict[str, int | None]) -> None:
    """Every option of ``serve`` that can be checked without opening a port: exit 2 with one line.
    ``view_host`` is None without --view."""
    if log_level.upper() not in _LOG_LEVELS:
        user_error(f"--log-level: one of {', '.join(_LOG_LEVELS)} (any case), got {log_level!r}")
    for name, value in ports.items():
        check_port(name, value)
    for name, h in (("--host", host), ("--view-host", view_host)):
        problem = None if h is None else check_host(name, h)
        if problem is not None:
            user_error(problem)
    if view_host is not None:
        try:
            import viser  # noqa: F401  # the "view" extra
        except ImportError:
            user_error("--view: the 3D view needs viser: pip install 'xarm-emu[view]'")


def check_run_options(record: Path | None, fleet: Path | None, loop: str, speed: float) -> None:
    """--record beside --fleet, --loop and --speed: exit 2 with one line."""
    if record is not None and fleet is not None:
        err_console.print("--record: with --fleet, record each arm with `xarm-emu record --port ...`")
        raise typer.Exit(2)
    if loop not in ("asyncio", "uvloop"):
        err_console.print("--loop is asyncio or uvloop")
        raise typer.Exit(2)
    if not (math.isfinite(speed) and speed > 0):
        err_console.print("--speed must be a positive number")
        raise typer.Exit(2)


def calibrated_model(robot: RobotModel, path: Path | None) -> RobotModel:
    """``robot`` with the calibration file at ``path`` (``--calibration``); one line and exit 2 for a
    file that cannot be used."""
    if path is None:
        return robot
    try:
        return with_calibration(robot, load_calibration(path))
    except CalibrationError as exc:
        err_console.print(f"--calibration: {exc}")
        raise typer.Exit(2) from None


def checked_arm(model: str, firmware: str, calibration: Path | None, linear_track: int | None,
                gripper: str | None, vacuum: bool,
                ft_sensor: bool = False) -> tuple[FirmwareProfile, RobotModel]:
    """The firmware profile and the arm's model (calibrated if asked) after every check of the box's
    options: exit 2 with one line for a firmware, model, linear track or gripper it cannot have. A
    part the firmware cannot drive (the arm or any device) is refused by the one rule of
    ``FirmwareProfile.check_parts``, in the same words for every part."""
    from ..controller.emulator import GRIPPERS, check_firmware
    from ..protocol.firmware import FirmwareRefusal

    try:
        profile = profile_for(firmware)
    except VersionError as exc:
        user_error(f"--firmware: {exc}")
    try:
        robot = calibrated_model(get_model(model), calibration)
    except ValueError as exc:
        user_error(f"--model: {exc}")
    if linear_track is not None:
        from ..controller.devices.linear_track import check_length

        try:
            check_length(linear_track)
        except ValueError as exc:
            user_error(f"--linear-track: {exc}")
    if gripper is not None and gripper not in GRIPPERS:
        user_error(f"--gripper: one of {', '.join(GRIPPERS)}, got {gripper!r}")
    if gripper is not None and vacuum:
        user_error("--gripper and --vacuum: one end tool at a time")
    try:
        check_firmware(robot, profile, gripper=gripper or "xarm", vacuum=vacuum, linear_track=linear_track,
                       ft_sensor=ft_sensor)
    except FirmwareRefusal as exc:
        user_error(f"--firmware: {exc}")
    return profile, robot
