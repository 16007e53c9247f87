"""``serve`` once its options are checked: the servers composed (one arm, or a fleet file's arms in this
process), the plug-ins attached (recording, Modbus port, Studio calls), started, printed and served
until SIGTERM or Ctrl-C; a server that cannot start gets one line and its exit status."""

from __future__ import annotations

import asyncio
import contextlib
import errno
import re
import signal
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from .. import __version__
from ..model.robots import RobotModel
from ..protocol.firmware import FirmwareProfile
from .options import check_host, console, err_console, user_error

if TYPE_CHECKING:
    from ..server.app import EmulatorServer, ServerConfig


def attach_record(srv: EmulatorServer, path: Path) -> None:
    """``serve --record``: the session goes to a Rerun recording (record.py)."""
    from ..record import RecordError, attach_recorder

    try:
        attach_recorder(srv, path)
    except (RecordError, ValueError) as exc:
        user_error(f"--record: {exc}")
    console.print(f"recording to {path}; open it with: rerun {path}", soft_wrap=True)


def attach_plc_ports(servers: list[EmulatorServer], host: str, modbus_port: int | None,
                      studio_port: int | None) -> None:
    """--modbus-port and --studio: the Modbus map on a port of its own, the Studio HTTP calls; one arm
    only (a fleet's arms would need one port each)."""
    if modbus_port is None and studio_port is None:
        return
    if len(servers) != 1:
        user_error("--modbus-port, --studio: one arm only, not with --fleet")
    from ..server.modbus_port import attach_modbus_port
    from ..server.studio import attach_studio

    if modbus_port is not None:
        attach_modbus_port(servers[0], host, modbus_port)
    if studio_port is not None:
        attach_studio(servers[0], host, studio_port)


def compose_servers(cfg: ServerConfig, fleet: Path | None, model: RobotModel, vacuum: bool,
                     cdir: Path, firmware: FirmwareProfile, linear_track: int | None = None, *,
                     ft_sensor: bool = False, scene: Path | None = None,
                     gripper: str = "xarm") -> tuple[list[EmulatorServer], Path]:
    """The servers to run (one, or a fleet file's arms) with their fault schedules scheduled and the
    3D view attached where asked; raises ValueError (FleetError, FaultScheduleError) before any
    port opens. Returns them and the configuration directory they use."""
    from ..controller.emulator import Emulator
    from ..controller.scene.contact import load_scene
    from ..server.app import EmulatorServer
    from ..server.faults import schedule_file
    from ..server.fleet import load_fleet
    from ..viewer.app import attach_fleet_view, attach_viewer

    if fleet is not None:
        spec = load_fleet(fleet)
        for i, arm in enumerate(spec.arms, start=1):
            problem = check_host(f"{fleet}: arm {i} host", arm.server.host)
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


async def serve_all(servers: list[EmulatorServer], cdir: Path) -> None:
    """Start every server, print where it listens, and serve until SIGTERM or Ctrl-C."""
    from ..protocol.admin import admin_host

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


def start_error(exc: Exception, host: str, port: int, fleet: bool) -> tuple[str | None, int]:
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


def run(coro: Any, loop: str) -> None:
    if loop == "uvloop":
        try:
            import uvloop  # type: ignore[import-not-found]
        except ImportError:
            err_console.print("uvloop is not installed; using the standard asyncio loop")
        else:
            uvloop.run(coro)
            return
    asyncio.run(coro)



#: Runs the servers on the chosen event loop; the package points it at ``xarm_emu.cli._run``, the one
#: place a test replaces to see what ``serve`` does when a port cannot be bound.
runner: Callable[[Any, str], None] = run


def start(cfg: ServerConfig, fleet: Path | None, robot: RobotModel, vacuum: bool, cdir: Path,
          profile: FirmwareProfile, linear_track: int | None, loop: str, *, ft_sensor: bool,
          scene: Path | None, gripper: str | None, record: Path | None, modbus_port: int | None,
          studio_port: int | None) -> None:
    """Compose the servers, attach what was asked and serve until SIGTERM or Ctrl-C: exit 2 for a bad
    fleet file or fault schedule (nothing has started), one line and its status when a port fails."""
    try:
        servers, cdir = compose_servers(cfg, fleet, robot, vacuum, cdir, profile, linear_track,
                                        ft_sensor=ft_sensor, scene=scene,
                                        gripper=gripper or "xarm")
    except ValueError as exc:  # a bad fleet file or fault schedule: nothing has started
        err_console.print(str(exc))
        raise typer.Exit(2) from None
    if record is not None:
        attach_record(servers[0], record)
    attach_plc_ports(servers, cfg.host, modbus_port, studio_port)
    for srv in servers:
        if srv.emulator.config_message:
            err_console.print(srv.emulator.config_message, style="yellow")
    try:
        runner(serve_all(servers, cdir), loop)
    except (PermissionError, ValueError, RuntimeError, OSError) as exc:
        message, code = start_error(exc, cfg.host, cfg.port, fleet is not None)
        if message is None:
            raise
        err_console.print(message)
        raise typer.Exit(code) from None
    except KeyboardInterrupt:
        pass
