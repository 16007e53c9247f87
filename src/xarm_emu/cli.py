"""``xarm-emu``: run the emulator and talk to a control box from the shell."""

from __future__ import annotations

import asyncio
import contextlib
import errno
import inspect
import json
import math
import re
import signal
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, NoReturn, cast

import typer
from rich.console import Console
from rich.table import Table
from typer.core import TyperCommand

from . import __version__
from .fidelity.commands import calibrated_model as _calibrated
from .fidelity.commands import register as _register_fidelity
from .model.robots import MODEL_NAMES, RobotModel, get_model
from .protocol import codes
from .protocol.firmware import SERVE_VERSION, SUPPORTED_VERSIONS, FirmwareProfile, VersionError, profile_for
from .protocol.frame import COMMAND_PORT
from .protocol.reports import DEVELOP_PORT, NORMAL_PORT, RICH_PORT
from .scene_cli import register as _register_scene
from .server.report_sender import DEFAULT_PRIORITY as DEFAULT_REPORT_PRIORITY

if TYPE_CHECKING:
    from .server.app import EmulatorServer, ServerConfig

app = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode=None,
                  help="Emulator of the UFACTORY xArm control box (xArm 5/6/7, Lite 6, 850, 7T; "
                       "Developer Manual V1.6.0 and firmware 2.x).\n\n"
                       "Exit status: 0 done; 2 a usage or input mistake (an option or argument the "
                       "command refuses); 1 a runtime failure (the box unreachable, a port in use, the "
                       "admin channel refusing the token). Either way one line on stderr says what to "
                       "do next.")
# Markup off: messages show square brackets as written (``xarm-emu[view]``, ``[[arm]]``).
console = Console(markup=False, highlight=False)
err_console = Console(stderr=True, markup=False, highlight=False, soft_wrap=True)

_STATES = {1: "in motion", 2: "sleep (ready)", 3: "suspend", 4: "stop", 5: "system reset"}
_MODES = {0: "position", 1: "servo", 2: "joint teaching", 3: "cartesian teaching"}


def _default_config_dir() -> Path:
    from .controller.core.config import default_config_dir

    return default_config_dir()


class _ServeCommand(TyperCommand):
    """``serve``, whose ``--linear-track`` may be given bare (the default stroke)."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        return super().parse_args(ctx, bare_linear_track(args))


def bare_linear_track(args: list[str]) -> list[str]:
    """``--linear-track`` without a length (last, or before another option) as the default stroke."""
    from .controller.devices.linear_track import DEFAULT_LENGTH

    out = list(args)
    for i, a in enumerate(out):
        if a == "--linear-track" and (i + 1 == len(out) or out[i + 1].startswith("-")):
            out[i] = f"--linear-track={DEFAULT_LENGTH}"
    return out


@app.command(cls=_ServeCommand)
def serve(
    model: Annotated[str, typer.Option(help="Arm model: " + ", ".join(MODEL_NAMES)
                                       + " (xArm 5/6/7, Lite 6, UFACTORY 850, xArm 7T).")] = "6",
    host: Annotated[str, typer.Option(help="Address to bind (loopback by default).")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Command port.")] = COMMAND_PORT,
    normal_port: Annotated[int, typer.Option(help="Normal report port (5 Hz).")] = NORMAL_PORT,
    rich_port: Annotated[int, typer.Option(help="Rich report port (5 Hz).")] = RICH_PORT,
    develop_port: Annotated[int, typer.Option(help="Develop report port (100 Hz).")] = DEVELOP_PORT,
    config_dir: Annotated[Path | None, typer.Option(help="Directory of saved configurations "
                                                         "(default: per-user config directory).")] = None,
    speed: Annotated[float, typer.Option(help="Time scale: 10 runs ten times faster than real time.")] = 1.0,
    log_level: Annotated[str, typer.Option(help="Logging level.")] = "INFO",
    admin: Annotated[bool, typer.Option("--admin", help="Open the fault-injection admin channel "
                                                         "(loopback only; see `xarm-emu inject`).")] = False,
    admin_port: Annotated[int | None, typer.Option(help="Admin channel port (default: command port "
                                                        "+ 10000, e.g. 10502).")] = None,
    view: Annotated[bool, typer.Option("--view", help="Serve the 3D view in the browser (needs the "
                                                       "'view' extra: viser).")] = False,
    view_host: Annotated[str | None, typer.Option(help="Address of the 3D view (default: --host).")] = None,
    view_port: Annotated[int, typer.Option(help="Port of the 3D view.")] = 8080,
    stepped: Annotated[bool, typer.Option("--stepped", help="Lockstep time: the controller advances only "
                                                            "by `xarm-emu step` (needs --admin).")] = False,
    loop: Annotated[str, typer.Option(help="Event loop: asyncio (default: the steadiest 100 Hz report in "
                                           "`make bench`) or uvloop.")] = "asyncio",
    firmware: Annotated[str, typer.Option(help="Firmware version the box claims and behaves as: "
                                               + ", ".join(SUPPORTED_VERSIONS) + ".")] = SERVE_VERSION,
    vacuum: Annotated[bool, typer.Option("--vacuum", help="Attach the xArm Vacuum Gripper: its pressure "
                                                           "switch answers on tool input 0.")] = False,
    linear_track: Annotated[int | None, typer.Option(
        "--linear-track", metavar="[LENGTH_MM]",
        help="Attach a UFACTORY linear track on the control box RS-485: its stroke, 700, 1000 or "
             "1500 mm (bare: 700).")] = None,
    ft_sensor: Annotated[bool, typer.Option("--ft-sensor", help="Mount the six-axis F/T sensor between "
                                                                 "flange and tool.")] = False,
    scene: Annotated[Path | None, typer.Option(help="Contact scene: planes and boxes the TCP presses "
                                                    "into, a TOML file "
                                                    "(controller/scene/contact.py).")] = None,
    gripper: Annotated[str | None, typer.Option(help="The gripper on the tool RS-485: xarm (the default), "
                                                     "robotiq-2f85, robotiq-2f140, bio, bio-g1 "
                                                     "(the first-generation BIO) or inspire-rh56 (the "
                                                     "Inspire RH56 hand).")] = None,
    trace: Annotated[Path | None, typer.Option(help="Append every command-port request and reply to "
                                                    "this JSON-lines file (see server/trace.py).")] = None,
    faults: Annotated[Path | None, typer.Option(help="Inject the faults and inputs this TOML schedule "
                                                     "lists at their controller times (server/faults.py).")
                      ] = None,
    fleet: Annotated[Path | None, typer.Option(help="Serve the arms a TOML fleet file lists, in worker "
                                                    "processes (see src/xarm_emu/server/fleet.py); the "
                                                    "per-arm options above then come from the file.")] = None,
    workers: Annotated[int | None, typer.Option(help="With --fleet: worker processes sharing the arms "
                                                     "(default: one per available CPU; 0: every arm in "
                                                     "this process, the default with --view). A worker "
                                                     "that dies is restarted with its arms.")] = None,
    record: Annotated[Path | None, typer.Option(help="Record the session (reports, commands, errors, the "
                                                     "arm's geometry) to this Rerun .rrd file; open it "
                                                     "with `rerun FILE` (needs the 'record' extra).")
                      ] = None,
    log_json: Annotated[bool, typer.Option("--log-json", help="Log one JSON object per line (time, "
                                                              "level, logger, message).")] = False,
    max_connections: Annotated[int, typer.Option(help="Connections accepted per port (command and each "
                                                      "report port); beyond it new ones are closed at once. "
                                                      "0: the open-file limit (raised to its hard limit "
                                                      "at start) less 64, divided by 4 ports, at most "
                                                      "1000 (1000 from a hard limit of 4064 up).",
                                                 min=0)] = 0,
    frame_timeout: Annotated[float, typer.Option(help="Close a command connection whose first or partial "
                                                      "frame is older than this (seconds; 0: never).",
                                                 min=0.0)] = 60.0,
    backlog: Annotated[int, typer.Option(help="Listen backlog of every port (bursts of connects).",
                                         min=1)] = 4096,
    log_file: Annotated[Path | None, typer.Option(help="Write the log to this file instead of stderr.")
                        ] = None,
    log_max_bytes: Annotated[int, typer.Option(help="Rotate --log-file at this size, keeping 3 old "
                                                    "files (0: never).", min=0)] = 0,
    trace_max_bytes: Annotated[int, typer.Option(help="Rotate --trace to FILE.1 at this size (0: never).",
                                                 min=0)] = 0,
    modbus_port: Annotated[int | None, typer.Option(help="Also serve the standard Modbus-TCP map "
                                                         "(protocol 0) on this port, for PLC and SCADA "
                                                         "tools that cannot share the command port.")
                           ] = None,
    studio: Annotated[bool, typer.Option("--studio", help="Answer the SDK's xArm Studio HTTP calls "
                                                           "(initial point, mount, trajectories).")] = False,
    studio_port: Annotated[int, typer.Option(help="Port of --studio (the SDK uses 18333).")] = 18333,
    calibration: Annotated[Path | None, typer.Option(help="Replace the emulator's estimated constants "
                                                          "with this calibration file (xarm-emu calibrate).")
                           ] = None,
    report_priority: Annotated[int | None, typer.Option(
        help="Real-time (SCHED_FIFO) priority 1-99 of the thread that sends the report frames (Linux, "
             "needs the privilege; a refusal is a warning); 0: normal scheduling. Default: priority "
             f"{DEFAULT_REPORT_PRIORITY} where the system allows it, else normal scheduling.",
        min=0, max=99, show_default=False)] = None,
) -> None:
    """Run the emulator with its command port and report ports.

    A serving process sets interpreter-wide settings for its report sender that a library user's
    process never gets: a 0.2 ms switch interval and frozen start-up objects (see
    ``report_sender.tune_process``), and real-time priority for the sender where allowed
    (``--report-priority``)."""
    from .server.app import ServerConfig
    from .server.fairness import Limits
    from .server.logs import configure

    _check_serve_options(log_level, host, (view_host or host) if view else None, {
        "--port": port, "--normal-port": normal_port, "--rich-port": rich_port,
        "--develop-port": develop_port, "--admin-port": admin_port, "--view-port": view_port,
        "--modbus-port": modbus_port, "--studio-port": studio_port if studio else None})
    configure(log_level, log_file, log_max_bytes, json_lines=log_json)
    from .server.fairness import raise_file_limit

    raise_file_limit()
    if record is not None and fleet is not None:
        err_console.print("--record: with --fleet, record each arm with `xarm-emu record --port ...`")
        raise typer.Exit(2)
    if loop not in ("asyncio", "uvloop"):
        err_console.print("--loop is asyncio or uvloop")
        raise typer.Exit(2)
    if not (math.isfinite(speed) and speed > 0):
        err_console.print("--speed must be a positive number")
        raise typer.Exit(2)
    cdir = config_dir if config_dir is not None else _default_config_dir()
    cfg = ServerConfig(host=host, port=port, normal_port=normal_port, rich_port=rich_port,
                       develop_port=develop_port, speed=speed, admin=admin, admin_port=admin_port,
                       view=view, view_host=view_host or host, view_port=view_port, stepped=stepped,
                       trace=trace, faults=faults)
    cfg.limits = Limits(max_connections=max_connections, frame_timeout=frame_timeout, backlog=backlog)
    cfg.trace_max_bytes = trace_max_bytes
    cfg.report_priority = report_priority
    from .server.report_sender import tune_process

    tune_process()  # a process that only serves arms: the report sender's interpreter settings
    try:
        profile = profile_for(firmware)
    except VersionError as exc:
        err_console.print(f"--firmware: {exc}")
        raise typer.Exit(2) from None
    from .controller.emulator import check_firmware

    try:
        robot = get_model(model)
        check_firmware(robot, profile)
        robot = _calibrated(robot, calibration)
    except ValueError as exc:
        err_console.print(f"--model: {exc}")
        raise typer.Exit(2) from None
    if linear_track is not None:
        from .controller.devices.linear_track import TRACK_FIRMWARE, check_length

        try:
            check_length(linear_track)
        except ValueError as exc:
            _user_error(f"--linear-track: {exc}")
        if not profile.version.at_least(TRACK_FIRMWARE):
            _user_error(f"--linear-track: needs firmware {TRACK_FIRMWARE} or later, not {profile}")
    from .controller.emulator import GRIPPERS

    if gripper is not None and gripper not in GRIPPERS:
        _user_error(f"--gripper: one of {', '.join(GRIPPERS)}, got {gripper!r}")
    if gripper is not None and vacuum:
        _user_error("--gripper and --vacuum: one end tool at a time")
    if fleet is not None:
        _refuse_per_arm_flags(cfg, robot is not get_model(6), vacuum or gripper is not None,
                              firmware != SERVE_VERSION,
                              linear_track is not None, ft_sensor=ft_sensor, scene=scene is not None)
    n_workers = _check_workers(workers, fleet, view, record, modbus_port, studio)
    if fleet is not None and n_workers > 0:
        from .server.workers import LogSettings

        _serve_fleet_workers(fleet, cfg, cdir, n_workers, LogSettings(log_level.upper(), log_file, log_json),
                             loop == "uvloop")
        return
    try:
        servers, cdir = _compose_servers(cfg, fleet, robot, vacuum, cdir, profile, linear_track,
                                         ft_sensor=ft_sensor, scene=scene,
                                         gripper=gripper or "xarm")
    except ValueError as exc:  # a bad fleet file or fault schedule: nothing has started
        err_console.print(str(exc))
        raise typer.Exit(2) from None
    if record is not None:
        _attach_record(servers[0], record)
    _attach_plc_ports(servers, host, modbus_port, studio_port if studio else None)
    for srv in servers:
        if srv.emulator.config_message:
            err_console.print(srv.emulator.config_message, style="yellow")
    try:
        _run(_serve_all(servers, cdir), loop)
    except (PermissionError, ValueError, RuntimeError, OSError) as exc:
        message, code = _start_error(exc, host, port, fleet is not None)
        if message is None:
            raise
        err_console.print(message)
        raise typer.Exit(code) from None
    except KeyboardInterrupt:
        pass


#: Options of ``serve`` that are per arm, so refused beside --fleet (the fleet file gives them);
#: --view beside --fleet serves one view of every arm.
_PER_ARM = ("host", "port", "normal_port", "rich_port", "develop_port", "speed", "admin", "admin_port",
            "stepped", "trace", "faults")


_LOG_LEVELS = ("CRITICAL", "ERROR", "WARNING", "INFO", "DEBUG")


def _user_error(message: str) -> NoReturn:
    """One line on stderr and exit 2: a bad option, found before any port opens."""
    err_console.print(message)
    raise typer.Exit(2)


def _check_port(name: str, value: int | None) -> None:
    if value is not None and not 0 <= value <= 65535:
        _user_error(f"{name}: a port is 0..65535 (0: any free port), got {value}")


def _check_host(name: str, host: str) -> str | None:
    """None if ``host`` is an address of this machine that a server can bind, else why not."""
    import socket

    try:
        infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError) as exc:
        return f"{name}: cannot resolve {host!r} ({getattr(exc, 'strerror', None) or exc})"
    family, _, _, _, addr = infos[0]
    try:
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.bind((addr[0], 0, *addr[2:]))
    except OSError as exc:
        return (f"{name}: {host!r} is not an address of this machine ({exc.strerror or exc}); "
                "use 127.0.0.1, 0.0.0.0 or one of its own addresses")
    return None


def _check_serve_options(log_level: str, host: str, view_host: str | None,
                         ports: dict[str, int | None]) -> None:
    """Every option of ``serve`` that can be checked without opening a port: exit 2 with one line.
    ``view_host`` is None without --view."""
    if log_level.upper() not in _LOG_LEVELS:
        _user_error(f"--log-level: one of {', '.join(_LOG_LEVELS)} (any case), got {log_level!r}")
    for name, value in ports.items():
        _check_port(name, value)
    for name, h in (("--host", host), ("--view-host", view_host)):
        problem = None if h is None else _check_host(name, h)
        if problem is not None:
            _user_error(problem)
    if view_host is not None:
        try:
            import viser  # noqa: F401  # the "view" extra
        except ImportError:
            _user_error("--view: the 3D view needs viser: pip install 'xarm-emu[view]'")


def _attach_record(srv: EmulatorServer, path: Path) -> None:
    """``serve --record``: the session goes to a Rerun recording (record.py)."""
    from .record import RecordError, attach_recorder

    try:
        attach_recorder(srv, path)
    except (RecordError, ValueError) as exc:
        _user_error(f"--record: {exc}")
    console.print(f"recording to {path}; open it with: rerun {path}", soft_wrap=True)


def _attach_plc_ports(servers: list[EmulatorServer], host: str, modbus_port: int | None,
                      studio_port: int | None) -> None:
    """--modbus-port and --studio: the Modbus map on a port of its own, the Studio HTTP calls; one arm
    only (a fleet's arms would need one port each)."""
    if modbus_port is None and studio_port is None:
        return
    if len(servers) != 1:
        _user_error("--modbus-port, --studio: one arm only, not with --fleet")
    from .server.modbus_port import attach_modbus_port
    from .server.studio import attach_studio

    if modbus_port is not None:
        attach_modbus_port(servers[0], host, modbus_port)
    if studio_port is not None:
        attach_studio(servers[0], host, studio_port)


def _refuse_per_arm_flags(given: ServerConfig, model: bool, vacuum: bool, firmware: bool,
                          track: bool = False, *, ft_sensor: bool = False, scene: bool = False) -> None:
    """Exit 2 naming every per-arm option given beside --fleet."""
    from .server.app import ServerConfig

    defaults = ServerConfig()
    per_arm = {"--model": model, "--vacuum/--gripper": vacuum, "--firmware": firmware,
               "--linear-track": track,
               "--ft-sensor": ft_sensor, "--scene": scene,
               **{"--" + k.replace("_", "-"): getattr(given, k) != getattr(defaults, k) for k in _PER_ARM}}
    named = [name for name, on in per_arm.items() if on]
    if named:
        err_console.print(f"{', '.join(named)}: with --fleet every arm's options come from the fleet "
                          "file (see src/xarm_emu/server/fleet.py)")
        raise typer.Exit(2)


def _compose_servers(cfg: ServerConfig, fleet: Path | None, model: RobotModel, vacuum: bool,
                     cdir: Path, firmware: FirmwareProfile, linear_track: int | None = None, *,
                     ft_sensor: bool = False, scene: Path | None = None,
                     gripper: str = "xarm") -> tuple[list[EmulatorServer], Path]:
    """The servers to run (one, or a fleet file's arms) with their fault schedules scheduled and the
    3D view attached where asked; raises ValueError (FleetError, FaultScheduleError) before any
    port opens. Returns them and the configuration directory they use."""
    from .controller.emulator import Emulator
    from .controller.scene.contact import load_scene
    from .server.app import EmulatorServer
    from .server.faults import schedule_file
    from .server.fleet import load_fleet
    from .viewer.app import attach_fleet_view, attach_viewer

    if fleet is not None:
        spec = load_fleet(fleet)
        for i, arm in enumerate(spec.arms, start=1):
            problem = _check_host(f"{fleet}: arm {i} host", arm.server.host)
            if problem is not None:
                raise ValueError(problem)
        cdir = spec.config_dir if spec.config_dir is not None else cdir
        arms = [(a.emulator(cdir), a.server) for a in spec.arms]
    else:
        contact_scene = None if scene is None else load_scene(scene)  # ValueError: one line
        arms = [(Emulator(model, config_dir=cdir, vacuum=vacuum, firmware=firmware,
                          linear_track=linear_track, ft_sensor=ft_sensor, gripper=gripper,
                          scene=contact_scene), cfg)]
    servers = []
    for emu, arm_cfg in arms:
        arm_cfg.limits = cfg.limits
        arm_cfg.report_priority = cfg.report_priority  # one report sender per process
        store = getattr(emu, "_store", None)
        if store is not None:  # one running box per saved configuration (controller/core/config.py)
            store.lock()
        srv = EmulatorServer(emu, arm_cfg)
        schedule_file(srv, arm_cfg.faults)
        attach_viewer(srv)
        servers.append(srv)
    if fleet is not None and cfg.view:  # one view listing the fleet's arms
        attach_fleet_view(servers, cfg.view_host, cfg.view_port)
    return servers, cdir


async def _serve_all(servers: list[EmulatorServer], cdir: Path) -> None:
    """Start every server, print where it listens, and serve until SIGTERM or Ctrl-C."""
    from .protocol.admin import admin_host

    for srv in servers:
        await srv.start()
        emu, cfg = srv.emulator, srv.config
        # One clause a line, each short of 80 columns but for long paths, never wrapped mid-clause.
        for line in (f"xarm-emu {__version__}: {emu.model.name} ({emu.controller.version_string()}) "
                     f"on {cfg.host}",
                     f"  ports: command {srv.ports['command']}, normal {srv.ports['normal']}, "
                     f"rich {srv.ports['rich']}, develop {srv.ports['develop']}",
                     "  " + ("lockstep time (xarm-emu step)" if cfg.stepped else f"speed x{cfg.speed:g}")
                     + f"; config {cdir}"):
            console.print(line, soft_wrap=True)
        if "admin" in srv.ports:
            where = f"{admin_host(cfg.host)}:{srv.ports['admin']}"
            console.print(f"admin channel (fault injection) on {where}")
        if "view" in srv.ports:
            console.print(f"3D view on http://{srv.viewer.host}:{srv.ports['view']}/")
        if "modbus" in srv.ports:
            console.print(f"standard Modbus TCP on {cfg.host}:{srv.ports['modbus']}")
        if "studio" in srv.ports:
            console.print(f"Studio HTTP calls on http://{cfg.host}:{srv.ports['studio']}/")
    # SIGTERM (docker stop, CI teardown) and Ctrl-C close every arm cleanly: connections end,
    # traces and logs are flushed, and the process exits 0.
    loop = asyncio.get_running_loop()
    closing: list[asyncio.Task[Any]] = []

    def shut_down() -> None:
        if not closing:
            closing.extend(asyncio.ensure_future(srv.close()) for srv in servers)

    for sig in (signal.SIGTERM, signal.SIGINT):
        with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):  # not on Windows
            loop.add_signal_handler(sig, shut_down)
    await asyncio.gather(*(srv.serve_forever() for srv in servers))


def _check_workers(workers: int | None, fleet: Path | None, view: bool, record: Path | None,
                   modbus_port: int | None, studio: bool) -> int:
    """The number of fleet worker processes (0: every arm in this process); exit 2 on a bad one."""
    from .server.workers import WorkersError, check_workers, default_workers

    if workers is None:
        return 0 if fleet is None or view else default_workers()
    if fleet is None:
        _user_error("--workers: only with --fleet (a single arm runs in this process)")
    try:
        n = check_workers(workers)
    except WorkersError as exc:
        _user_error(str(exc))
    if n and (view or record is not None or modbus_port is not None or studio):
        _user_error("--workers: --view serves a fleet's arms from this process; give --workers 0 "
                    "(or leave --workers out)")
    return n


def _serve_fleet_workers(fleet: Path, cfg: ServerConfig, cdir: Path, workers: int, logs: Any,
                         use_uvloop: bool) -> None:
    """``serve --fleet FILE --workers N``: the arms in N supervised worker processes
    (server/workers.py) until SIGTERM or Ctrl-C; every check of the file first (exit 2)."""
    from .protocol.admin import admin_host
    from .server.workers import ArmReady, Supervisor, WorkerPlan, plans

    try:
        spec, cdir = _check_fleet(fleet, cdir)
    except ValueError as exc:
        _user_error(str(exc))

    def ready(plan: WorkerPlan, starts: int, arms: list[ArmReady]) -> None:
        for arm, srv_cfg in zip(arms, (s.server for s in plan.specs), strict=True):
            p = arm.ports
            again = " (restarted)" if starts > 1 else ""
            console.print(f"xarm-emu {__version__}: {arm.model} ({arm.version}) on {arm.host}: command "
                          f"{p['command']}, normal {p['normal']}, rich {p['rich']}, develop {p['develop']}; "
                          f"speed x{srv_cfg.speed:g}; config {cdir}; worker {plan.index}{again}")
            if "admin" in p:
                console.print(f"admin channel (fault injection) on {admin_host(arm.host)}:{p['admin']}")
            if arm.config_message and starts == 1:
                err_console.print(arm.config_message, style="yellow")
        console.print(f"fleet worker {plan.index} (pid {arms[0].pid}): arms "
                      f"{', '.join(map(str, plan.numbers))}" + (" (restarted)" if starts > 1 else ""))

    sup = Supervisor(plans(spec.arms, workers, cdir, cfg.limits, logs, use_uvloop, cfg.report_priority),
                     ready)
    try:
        sup.start()
    except (PermissionError, ValueError, RuntimeError, OSError) as exc:
        message, code = _start_error(exc, cfg.host, cfg.port, True)
        err_console.print(message if message is not None else str(exc))
        raise typer.Exit(code or 1) from None
    # SIGTERM (docker stop, CI teardown) and Ctrl-C stop every worker cleanly; the parent exits 0.
    previous = {sig: signal.signal(sig, lambda *_: sup.request_stop()) for sig in (signal.SIGTERM,
                                                                                  signal.SIGINT)}
    try:
        sup.run()
    finally:
        sup.stop()
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _check_fleet(fleet: Path, cdir: Path) -> tuple[Any, Path]:
    """Load and check a fleet file for worker processes: hosts, fault schedules (against a throwaway
    box of each arm's model) and that no saved configuration is in use; raises ValueError."""
    from .controller.core.config import ConfigStore
    from .controller.emulator import Emulator
    from .server.app import EmulatorServer
    from .server.faults import schedule_file
    from .server.fleet import load_fleet

    spec = load_fleet(fleet)
    for i, arm in enumerate(spec.arms, start=1):
        problem = _check_host(f"{fleet}: arm {i} host", arm.server.host)
        if problem is not None:
            raise ValueError(problem)
        if arm.server.faults is not None:
            probe = Emulator(arm.model, robot_sn=arm.robot_sn, vacuum=arm.vacuum, firmware=arm.firmware)
            schedule_file(EmulatorServer(probe, arm.server), arm.server.faults)
    cdir = spec.config_dir if spec.config_dir is not None else cdir
    for arm in spec.arms:  # the workers claim them; a holder elsewhere is found before any port opens
        store = ConfigStore(cdir, arm.robot_sn)
        store.lock()
        store.unlock()
    return spec, cdir


def _start_error(exc: Exception, host: str, port: int, fleet: bool) -> tuple[str | None, int]:
    """The one-line message and exit status for a server that could not start (None: not ours)."""
    if isinstance(exc, PermissionError):
        return (_PRIVILEGED.format(port=port, host=host) if not fleet else
                "cannot bind a port below 1024 of the fleet file: this process lacks the "
                "privilege; use ports from 1024 up or grant cap_net_bind_service"), 1
    if isinstance(exc, (ValueError, RuntimeError)):  # no default admin port; the view without viser
        return str(exc), 2
    if isinstance(exc, OSError) and exc.errno == errno.EACCES:
        return (_PRIVILEGED.format(port=port, host=host) if not fleet else
                f"cannot bind a port of the fleet file: {exc.strerror}"), 1
    if isinstance(exc, OSError) and exc.errno == errno.EADDRINUSE:
        taken = re.search(r", (\d+)\)", str(exc))  # asyncio names the address it could not bind
        where = f"{host}:{taken.group(1) if taken else port}"
        return (f"cannot bind {where}: the port is already in use (another emulator?); serve beside it "
                "on another loopback address with --host 127.0.0.N (N = 2, 3, ...) or choose other "
                "ports with --port/--normal-port/--rich-port/--develop-port"
                if not fleet else
                f"a port of the fleet file is already in use ({exc.strerror}): {exc}"), 1
    return None, 0


_PRIVILEGED = ("cannot bind port {port} on {host}: ports below 1024 need privileges this process lacks; "
               "run with --port 5020 (and point the SDK there by setting "
               "xarm.core.config.x_config.XCONF.SocketConf.TCP_CONTROL_PORT = 5020 before XArmAPI(...)), "
               "or grant the capability: sudo setcap 'cap_net_bind_service=+ep' "
               "$(readlink -f $(which python3))")


def _run(coro: Any, loop: str) -> None:
    if loop == "uvloop":
        try:
            import uvloop  # type: ignore[import-not-found]
        except ImportError:
            err_console.print("uvloop is not installed; using the standard asyncio loop")
        else:
            uvloop.run(coro)
            return
    asyncio.run(coro)


@app.command()
def status(
    host: Annotated[str, typer.Option(help="Control box address.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Command port.")] = COMMAND_PORT,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    report_port: Annotated[int, typer.Option(help="Develop report port, read for the mode.")] = DEVELOP_PORT,
    wait: Annotated[float, typer.Option(
        help="Readiness probe: retry for up to this many seconds until the control box answers on "
             "its command port (a protocol reply, not just an open port).")] = 0.0,
    linear_track: Annotated[bool, typer.Option(
        "--linear-track", help="Also read the linear track on the control box RS-485 (register 124, "
                               "host 11); off by default, as it talks to that bus.")] = False,
) -> None:
    """Print version, state, mode, error, warning, joints and pose of a control box (and its linear
    track with --linear-track).

    Exit status 1 when it cannot be reached (after ``--wait`` seconds of retries), so
    ``xarm-emu serve & xarm-emu status --wait 10`` is a CI readiness probe.
    """
    from .client import Client, ClientError, subscribe

    _check_port("--port", port)
    _check_port("--report-port", report_port)
    deadline = time.monotonic() + max(0.0, wait)
    while True:
        try:
            with Client(host, port, timeout=3.0) as c:
                version = c.get_version()
                state = c.get_state()
                error, warning = c.get_err_warn()
                joints = c.get_joints()
                pose = c.get_position()
                track = _track_status(c) if linear_track else None
                ft = _ft_status(c, version)
                gripper = _probe_gripper(c)
            break
        except (OSError, ClientError) as exc:
            if time.monotonic() < deadline:
                time.sleep(0.1)
                continue
            err_console.print(f"cannot reach the control box at {host}:{port}: {exc}")
            raise typer.Exit(1) from None
    mode: int | None = None
    try:  # no register reads the mode (manual 2.1.3): the report's state byte carries it
        mode = next(iter(subscribe("develop", host, report_port, timeout=2.0))).mode
    except (OSError, ClientError, StopIteration):
        mode = None
    axis = int(version.split(",")[0]) if version[:1].isdigit() else 7
    data = {"version": version, "state": state, "mode": mode, "error": error, "warning": warning,
            "joints": list(joints[:axis]), "pose": list(pose), "gripper": gripper,
            "joints_deg": [math.degrees(j) for j in joints[:axis]],
            "pose_mm_deg": [*pose[:3], *(math.degrees(p) for p in pose[3:])],
            "units": {"joints": "rad", "pose": "x, y, z mm; roll, pitch, yaw rad",
                      "joints_deg": "deg", "pose_mm_deg": "x, y, z mm; roll, pitch, yaw deg"}}
    if linear_track:  # null when nothing answers on the control box RS-485
        data["linear_track"] = track
        data["units"] = {**cast(dict[str, str], data["units"]), "linear_track": "position mm"}
    if ft is not None:
        data["ft_sensor"] = ft
    if as_json:
        print(json.dumps(data))
        return
    t = Table(show_header=False)
    t.add_row("version", version)
    t.add_row("state", f"{state} ({_STATES.get(state, '?')})")
    t.add_row("mode", "unknown (no report)" if mode is None else f"{mode} ({_MODES.get(mode, '?')})")
    t.add_row("error", codes.describe_error(error))
    t.add_row("warning", codes.describe_warning(warning))
    t.add_row("joints (deg)", ", ".join(f"{math.degrees(j):.3f}" for j in joints[:axis]))
    t.add_row("pose (mm, deg)", ", ".join([f"{p:.3f}" for p in pose[:3]] +
                                          [f"{math.degrees(p):.3f}" for p in pose[3:]]))
    if linear_track:
        t.add_row("linear track", "no answer on the control box RS-485" if track is None else
                  f"{track['position']:.3f} mm, "
                  + ("moving" if track["moving"] else "at rest") + ", "
                  + ("enabled" if track["enabled"] else "disabled") + ", "
                  + ("on zero" if track["on_zero"] else "not homed") + f", error {track['error']}")
    if ft is not None:
        t.add_row("F/T sensor", "on: " + ", ".join(f"{x:.3f}" for x in ft["reading"]) + " (N, N m)"
                  if ft["enabled"] else "mounted, switched off")
    t.add_row("gripper", ", ".join(f"{k} {v}" for k, v in gripper.items()) if gripper else
              "none answers on the tool RS-485 at its present baud rate")
    console.print(t)


def _ft_status(c: Any, version: str) -> dict[str, Any] | None:
    """The F/T sensor as registers 212 and 200 show it (firmware 1.8.3 and later: an older box has
    no register 212, and asking would raise its warning 13); None without a sensor."""
    from .protocol.firmware import FirmwareVersion

    try:
        fw = FirmwareVersion.parse(version.rsplit(",v", 1)[-1].lstrip("v"))
    except ValueError:
        return None
    if fw.parts < (1, 8, 3):
        return None
    config = c.call(212)
    if not config.values.get("type"):
        return None
    enabled = bool(config.values.get("started"))
    forces = list(c.call(200).values.get("forces", (0.0,) * 6)) if enabled else [0.0] * 6
    return {"enabled": enabled, "reading": [float(x) for x in forces],
            "units": "Fx, Fy, Fz N; Tx, Ty, Tz N m"}


def _track_status(c: Any) -> dict[str, Any] | None:
    """The linear track's registers 0x0A20-0x0A25 over register 124 (host 11, slave 1), or None
    when nothing answers on the control box RS-485."""
    from .protocol import rtu

    reply = c.call(124, host=rtu.CONTROL_BOX_HOST, rtu=rtu.read_request(1, 0x0A20, 6))
    try:
        slave, func, words = rtu.parse_reply(bytes(reply["rtu"]))
    except (KeyError, ValueError):
        return None
    if (slave, func) != (1, rtu.READ_HOLDING) or len(words) != 6:
        return None
    pulses = (words[0] << 16 | words[1]) - (1 << 32 if words[0] & 0x8000 else 0)
    return {"position": pulses / 2000, "moving": bool(words[2] & 1), "error": words[3],
            "enabled": bool(words[4] & 1), "on_zero": bool(words[5] & 1)}


def _tool_read(c: Any, slave: int, address: int, count: int) -> tuple[int, ...] | None:
    """Read holding registers of a tool RS-485 slave through register 124 (manual 2.1.4); None when
    nothing answers or the reply is an exception."""
    from .protocol import rtu

    try:
        r = c.call(124, host=rtu.TOOL_HOST, rtu=rtu.read_request(slave, address, count))
        slave_id, func, values = rtu.parse_reply(bytes(r["rtu"]))
    except (KeyError, ValueError):
        return None
    return tuple(values) if func == rtu.READ_HOLDING and slave_id == slave else None


def _probe_gripper(c: Any) -> dict[str, Any]:
    """Which gripper answers on the tool RS-485, read without changing its baud rate: a Robotiq
    (slave 9, status at 0x07D0), a BIO gripper (slave 8 with a serial number at 0x0B10) or the xArm
    gripper (slave 8); {} when none does."""
    robotiq = _tool_read(c, 9, 0x07D0, 3)
    if robotiq is not None:
        g_status, fault, g_pos = robotiq[0] >> 8, robotiq[1] >> 8, robotiq[2] >> 8
        return {"type": "robotiq", "gSTA": g_status >> 4 & 3, "gOBJ": g_status >> 6, "gPO": g_pos,
                "gFLT": fault & 0x0F}
    status = _tool_read(c, 8, 0x0000, 1)
    if status is None:
        return {}
    err = _tool_read(c, 8, 0x000F, 1) or (0,)
    pos = _tool_read(c, 8, 0x0702, 2) or (0, 0)
    position = int.from_bytes(bytes((pos[0] >> 8, pos[0] & 0xFF, pos[1] >> 8, pos[1] & 0xFF)), "big",
                              signed=True)
    kind = "bio" if _tool_read(c, 8, 0x0B10, 1) is not None else "xarm"
    return {"type": kind, "enabled": (status[0] >> 2 & 3) == 2, "motion": status[0] & 3,
            "position": position, "error": err[0]}


@app.command()
def registers(
    code: Annotated[int | None, typer.Argument(help="One register, e.g. 21.")] = None,
) -> None:
    """List the registers of the command port with their request and reply layouts (manual 2.1.3,
    2.1.4), read from the register table the emulator itself uses."""
    from .protocol.registers import REGISTERS

    if code is not None:
        reg = REGISTERS.get(code)
        if reg is None:
            err_console.print(f"no register {code}; `xarm-emu registers` lists them")
            raise typer.Exit(2)
        console.print(f"{reg.code} {reg.name}: {reg.title} (manual {reg.section})")
        console.print(f"  request: {reg.request.describe()}")
        console.print(f"  reply:   {reg.reply.describe()}")
        flags = [f.name.lower().replace("_", " ") for f in type(reg.flags) if f in reg.flags and f.name]
        if flags:
            console.print(f"  flags:   {', '.join(flags)}")
        if reg.doc:
            console.print(f"  {reg.doc}")
        from .controller.handlers import handled_by

        for line in handled_by(code):
            console.print(f"  {line}", soft_wrap=True)
        return
    # Plain lines (one per register), easy to grep: code, name, title; request -> reply.
    print("# command port registers: fp32/int32 little-endian, u16 big-endian (manual 2.1.2)")
    for reg in REGISTERS.values():
        print(f"{reg.code:3d} {reg.name:26s} {reg.title}\n    request: {reg.request.describe()}"
              f"\n    reply:   {reg.reply.describe()}")


@app.command("modbus-map")
def modbus_map(
    as_json: Annotated[bool, typer.Option("--json", help="One JSON object per point.")] = False,
) -> None:
    """Print the standard Modbus-TCP map (protocol id 0, unit 1): every point, its scaling and what a
    write does, from the emulator's own table."""
    from .protocol.modbus import MODBUS_MAP

    if as_json:
        for p in MODBUS_MAP:
            console.print(json.dumps({"table": p.kind.value, "address": p.address, "count": p.count,
                                      "name": p.name, "unit": p.unit, "scale": p.scale, "signed": p.signed,
                                      "writable": p.writable, "writes": p.writes, "doc": p.doc}),
                          soft_wrap=True)
        return
    rows = []
    for p in MODBUS_MAP:
        span = str(p.address) if p.count == 1 else f"{p.address}-{p.end - 1}"
        note = "; ".join(x for x in (p.writes and f"as register {p.writes}", p.doc) if x)
        rows.append((p.kind.value, span, p.name, p.unit,
                     "" if p.scale == 1 else f"x{p.scale:g}" + (" signed" if p.signed else ""),
                     "rw" if p.writable else "r", note))
    if console.width < 120:  # narrow or piped: a list, each point's note wrapped under it
        import textwrap

        for kind, span, name, unit, scale, rw, note in rows:
            head = " ".join(x for x in (kind, span, name, rw, unit and f"[{unit}]", scale) if x)
            console.print(head, soft_wrap=True)
            for line in textwrap.wrap(note, width=max(40, console.width - 4)):
                console.print("    " + line, soft_wrap=True)
        return
    table = Table("table", "addresses", "name", "unit", "scale", "rw", "note")
    for col in table.columns[1:3]:  # addresses and names stay whole
        col.no_wrap = True
    for row in rows:
        table.add_row(*row)
    console.print(table)


@app.command(name="codes")
def show_codes(
    label: Annotated[str | None, typer.Argument(help="One code, e.g. C31, W11, S23 or G11; a bare number "
                                                     "(31) is the control box error and warning of that "
                                                     "number, as registers 15 answers them.")] = None,
) -> None:
    """List the error and warning codes of manual chapter 3 with their handling, or explain one."""
    if label is not None:
        _explain_code(label)
        return
    for title, table in (("Control box errors (3.2.1)", codes.CONTROLLER_ERRORS),
                         ("Warnings (3.2.2)", codes.WARNINGS),
                         ("Joint (servo) errors (3.1)", codes.SERVO_ERRORS),
                         ("Gripper errors (3.3)", codes.GRIPPER_ERRORS)):
        t = Table(title=title)
        t.add_column("code")
        t.add_column("name")
        t.add_column("handling")
        for entry in table.values():
            t.add_row(entry.label, entry.name, entry.handling)
        console.print(t)


def _explain_code(label: str) -> None:
    """``codes C31`` or ``codes 31`` (the control box error, then the warning, of that number)."""
    text = label.strip()
    if text.isdigit():
        found = [e for e in (codes.lookup("C", int(text)), codes.lookup("W", int(text))) if e is not None]
        if not found:
            _user_error(f"{text} is neither a control box error nor a warning of the manual (3.2.1, 3.2.2)")
        for entry in found:
            console.print(entry.describe())
        return
    try:
        console.print(codes.parse_label(text).describe())
    except ValueError as exc:
        _user_error(str(exc))


# -- fault injection through the admin channel (server/admin.py) --------------------------------------
inject_app = typer.Typer(no_args_is_help=True, help=(
    "Inject a fault into an emulator started with `xarm-emu serve --admin`. The emulator is addressed "
    "by --host and --port (its command port, as for `status`); the admin channel listens on loopback at "
    "the command port + 10000 (502 -> 10502) unless the server was given --admin-port, in which case pass "
    "the same --admin-port here."))
app.add_typer(inject_app, name="inject")

HostOpt = Annotated[str, typer.Option(help="Emulator address (the admin channel is loopback only).")]
PortOpt = Annotated[int, typer.Option(help="The emulator's command port; the admin port is this + 10000.")]
AdminPortOpt = Annotated[int | None, typer.Option(help="Admin channel port, if the server was started "
                                                       "with --admin-port.")]


def _admin(host: str, port: int, admin_port: int | None, cmd: str, *, refused_exit: int = 2,
           **args: Any) -> str:
    """Send one admin request, print the emulator's answer and return it; exit ``refused_exit`` when
    it refuses an argument, 1 when there is no channel or it refuses the token."""
    from .client import ClientError
    from .client.admin import AdminClient, AdminRefused
    from .client.admin import admin_port as derive
    from .protocol.admin import admin_host

    _check_port("--port", port)
    _check_port("--admin-port", admin_port)
    try:
        aport = derive(port, admin_port)
    except ValueError as exc:
        err_console.print(str(exc))
        raise typer.Exit(2) from None
    host = admin_host(host)  # the admin channel is on loopback (protocol/admin.py)
    try:
        with AdminClient(host, aport, timeout=3.0) as a:
            message = a.request(cmd, **args)
    except AdminRefused as exc:
        err_console.print(f"refused: {exc}")
        raise typer.Exit(1 if "admin token" in str(exc) else refused_exit) from None
    except (OSError, ClientError) as exc:
        err_console.print(f"cannot reach the admin channel at {host}:{aport} ({exc}); start the emulator "
                          "with `xarm-emu serve --admin` and run this on the same machine")
        raise typer.Exit(1) from None
    if cmd not in ("checkpoint-list", "scene-objects"):
        console.print(message)
    return message


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
                                              "(gFLT) 14 or 0x0E, BIO gripper 11 or 12.")], "code"),)),
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
        _admin(kw.pop("host"), kw.pop("port"), kw.pop("admin_port"), cmd,
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


_register_scene(app, _admin, console)


@app.command()
def clear(host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT, admin_port: AdminPortOpt = None) -> None:
    """Clear every injected fault, the reply delay and the report pause (admin channel)."""
    _admin(host, port, admin_port, "clear")


@app.command("set-input", context_settings={"ignore_unknown_options": True})
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
                _user_error(f"{name}: a finite number of seconds >= 0, got {x}")
        if frame not in ("tool", "base"):
            _user_error(f"--frame: tool or base, got {frame!r}")
        args: dict[str, Any] = {"wrench": wrench, "frame": frame, "ramp": ramp}
        if hold is not None:
            args["for"] = hold
        _admin(host, port, admin_port, "set-input", refused_exit=2, kind="ft", **args)
        return
    if len(values) != 2:
        _user_error(f"set-input {kind}: INDEX VALUE, got {' '.join(values) or 'nothing'}")
    try:
        index, value = int(values[0]), float(values[1])
    except ValueError:
        _user_error(f"set-input {kind}: INDEX is an integer and VALUE a number, got {' '.join(values)}")
    _admin(host, port, admin_port, "set-input", kind=kind, index=index, value=value)


def _finite_numbers(values: list[str], n: int, what: str) -> list[float]:
    """``n`` finite numbers from the command line, else one line and exit 2."""
    if len(values) != n:
        _user_error(f"{what}: {n} numbers, got {len(values)}")
    try:
        out = [float(v) for v in values]
    except ValueError:
        _user_error(f"{what}: numbers, got {' '.join(values)}")
    if not all(math.isfinite(x) for x in out):
        _user_error(f"{what}: finite numbers (no nan or inf), got {' '.join(values)}")
    return out


@app.command()
def step(
    duration: Annotated[str, typer.Argument(help="Controller time to run, e.g. 0.5s, 40ms.")],
    host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT, admin_port: AdminPortOpt = None,
) -> None:
    """Lockstep: run an emulator started with `serve --stepped --admin` for this much controller time."""
    _admin(host, port, admin_port, "step", seconds=duration)


# -- checkpoints through the admin channel (an emulator feature; no real control box has it) -------
checkpoint_app = typer.Typer(no_args_is_help=True, help=(
    "Keep the whole state of an emulator started with `xarm-emu serve --admin` under a name, and go "
    "back to it (in the emulator's memory, until it exits). Addressed as for `xarm-emu inject`."))
app.add_typer(checkpoint_app, name="checkpoint")

NameArg = Annotated[str, typer.Argument(help="Checkpoint name, e.g. before-pick.")]


def _checkpoint_name(name: str) -> str:
    from .protocol.admin import checkpoint_name

    try:
        return checkpoint_name(name)
    except ValueError as exc:
        err_console.print(str(exc))
        raise typer.Exit(2) from None


@checkpoint_app.command("save")
def checkpoint_save(name: NameArg, host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
                    admin_port: AdminPortOpt = None) -> None:
    """Keep the emulator's whole state (motion, faults, IO, settings) under NAME."""
    _admin(host, port, admin_port, "checkpoint-save", refused_exit=2, name=_checkpoint_name(name))


@checkpoint_app.command("restore")
def checkpoint_restore(name: NameArg, host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
                       admin_port: AdminPortOpt = None) -> None:
    """Put the emulator back to the state saved under NAME."""
    _admin(host, port, admin_port, "checkpoint-restore", refused_exit=2, name=_checkpoint_name(name))


@checkpoint_app.command("list")
def checkpoint_list(host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
                    admin_port: AdminPortOpt = None) -> None:
    """Print the saved checkpoint names, one per line."""
    names = json.loads(_admin(host, port, admin_port, "checkpoint-list", refused_exit=2))
    for name in names:
        console.print(name, markup=False, highlight=False)


# -- sessions: recorded, plotted, replayed ------------------------------------------------------------
@app.command("record")
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
    from .client import Client, ClientError
    from .record import RecordError, SessionRecorder, model_of, record_reports

    for name, value in (("--port", port), ("--develop-port", develop_port), ("--rich-port", rich_port)):
        _check_port(name, value)
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        _user_error("--duration must be a positive number of seconds")
    try:
        with Client(host, port, timeout=3.0) as c:
            version = c.get_version()
    except (OSError, ClientError) as exc:
        err_console.print(f"cannot reach the control box at {host}:{port}: {exc}")
        raise typer.Exit(1) from None
    try:
        recorder = SessionRecorder(out, model_of(version))
    except RecordError as exc:
        _user_error(str(exc))
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


@app.command("plot")
def plot_session(
    source: Annotated[Path, typer.Argument(help="A Rerun recording (.rrd, xarm-emu record) or a command "
                                                "trace (serve --trace).")],
    out: Annotated[Path, typer.Option("-o", "--output", help="PNG to write.")] = Path("run.png"),
    dof: Annotated[int | None, typer.Option(help="Joints to draw (default: all recorded).")] = None,
) -> None:
    """Draw joints, TCP path and speed, torques and events against time to a PNG."""
    from .plot import PlotError, plot, read

    if not source.exists():
        _user_error(f"no such file: {source}")
    try:
        plot(read(source), out, title=source.name, dof=dof)
    except PlotError as exc:
        _user_error(str(exc))
    console.print(f"wrote {out}", soft_wrap=True)


@app.command("replay")
def replay_trace(
    trace_file: Annotated[Path, typer.Argument(help="A command trace of `serve --trace`.")],
    model: Annotated[str, typer.Option(help="Arm model the trace was recorded with.")] = "6",
    firmware: Annotated[str | None, typer.Option(help="Firmware version of the recorded box (default: the "
                                                      "version its register 1 reply claimed, else serve's "
                                                      "default).")] = None,
    vacuum: Annotated[bool, typer.Option("--vacuum", help="The box had a vacuum gripper.")] = False,
    tolerance: Annotated[float, typer.Option(help="Largest difference of a decoded value that still "
                                                  "counts as the same.")] = 1e-6,
    all_differences: Annotated[bool, typer.Option("--all", help="List every differing reply, not only "
                                                               "the first.")] = False,
) -> None:
    """Send a recorded command trace into a fresh emulator in stepped time and compare the replies.

    Exit status 0 when every reply is the same, 1 at the first difference (printed), 2 for a bad
    trace or option."""
    from .replay import ReplayError, replay

    try:
        robot = get_model(model)
        if firmware is not None:
            from .controller.emulator import check_firmware

            check_firmware(robot, profile_for(firmware))
    except (ValueError, VersionError) as exc:
        _user_error(f"--model/--firmware: {exc}")
    try:
        result = replay(trace_file, model=model, firmware=firmware, vacuum=vacuum, tolerance=tolerance,
                        stop_at_first=not all_differences)
    except ReplayError as exc:
        _user_error(str(exc))
    if not result.differences:
        console.print(f"{result.requests} requests replayed: every reply is the same", soft_wrap=True)
        return
    first = result.differences[0].describe()
    console.print(f"{result.requests} requests replayed; first difference: {first}", soft_wrap=True)
    for diff in result.differences[1:]:
        console.print(f"  {diff.describe()}", soft_wrap=True)
    raise typer.Exit(1)


_register_fidelity(app)  # proxy, compare, calibrate (fidelity/commands.py)


@app.command()
def version() -> None:
    """Print the xarm-emu version."""
    console.print(__version__)


def main() -> None:
    app(auto_envvar_prefix="XARM_EMU")  # every option also from XARM_EMU_<COMMAND>_<OPTION>


if __name__ == "__main__":
    main()
