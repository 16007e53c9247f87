"""``serve --fleet FILE``: the per-arm options refused beside it, and the arms in supervised worker
processes (``--workers``, server/workers.py) with every check of the file made before any port opens."""

from __future__ import annotations

import signal
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from .. import __version__
from .options import check_host, console, err_console, user_error
from .serving import start_error

if TYPE_CHECKING:
    from ..server.app import ServerConfig

#: Options of ``serve`` that are per arm, so refused beside --fleet (the fleet file gives them);
#: --view beside --fleet serves one view of every arm.
_PER_ARM = ("host", "port", "normal_port", "rich_port", "develop_port", "speed", "admin", "admin_port",
            "stepped", "trace", "faults")


def refuse_per_arm_flags(given: ServerConfig, model: bool, vacuum: bool, firmware: bool,
                          track: bool = False, *, ft_sensor: bool = False, scene: bool = False) -> None:
    """Exit 2 naming every per-arm option given beside --fleet."""
    from ..server.app import ServerConfig

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


def check_workers(workers: int | None, fleet: Path | None, view: bool, record: Path | None,
                   modbus_port: int | None, studio: bool) -> int:
    """The number of fleet worker processes (0: every arm in this process); exit 2 on a bad one."""
    from ..server.workers import WorkersError, check_workers, default_workers

    if workers is None:
        return 0 if fleet is None or view else default_workers()
    if fleet is None:
        user_error("--workers: only with --fleet (a single arm runs in this process)")
    try:
        n = check_workers(workers)
    except WorkersError as exc:
        user_error(str(exc))
    if n and (view or record is not None or modbus_port is not None or studio):
        user_error("--workers: --view serves a fleet's arms from this process; give --workers 0 "
                    "(or leave --workers out)")
    return n


def serve_fleet_workers(fleet: Path, cfg: ServerConfig, cdir: Path, workers: int,
                        log: tuple[str, Path | None, bool], use_uvloop: bool) -> None:
    """``serve --fleet FILE --workers N``: the arms in N supervised worker processes
    (server/workers.py) until SIGTERM or Ctrl-C; every check of the file first (exit 2). ``log`` is
    the workers' log level, file and JSON-lines switch."""
    from ..protocol.admin import admin_host
    from ..server.workers import ArmReady, LogSettings, Supervisor, WorkerPlan, plans

    try:
        spec, cdir = _check_fleet(fleet, cdir)
    except ValueError as exc:
        user_error(str(exc))

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

    sup = Supervisor(plans(spec.arms, workers, cdir, cfg.limits, LogSettings(*log), use_uvloop,
                           cfg.report_priority),
                     ready)
    try:
        sup.start()
    except (PermissionError, ValueError, RuntimeError, OSError) as exc:
        message, code = start_error(exc, cfg.host, cfg.port, True)
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
    from ..controller.core.config import ConfigStore
    from ..controller.emulator import Emulator
    from ..server.app import EmulatorServer
    from ..server.faults import schedule_file
    from ..server.fleet import load_fleet

    spec = load_fleet(fleet)
    for i, arm in enumerate(spec.arms, start=1):
        problem = check_host(f"{fleet}: arm {i} host", arm.server.host)
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

