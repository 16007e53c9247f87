"""A fleet file: several emulated arms served together (``xarm-emu serve --fleet FILE``), in worker
processes supervised by the parent (:mod:`.workers`) or, with ``--workers 0``, in one process.

The SDK's ports are fixed (502, 30001-30003), so arms usually differ by loopback address
(127.0.0.0/8 on Linux), each with the standard ports; they may also differ by port. A TOML file
lists them; top-level keys are defaults for every arm::

    speed = 1.0                  # time scale shared by every arm
    config_dir = "fleet-config"  # saved configurations, one file per robot serial number

    [[arm]]
    model = 6
    host = "127.0.0.1"

    [[arm]]
    model = 7
    host = "127.0.0.2"
    robot_sn = "XS1302"
    admin = true                 # fault injection on 127.0.0.2:10502 (see xarm-emu inject)

Arm keys: ``model`` (5, 6, 7, or a name: lite6, 850, 7t), ``host``, ``port``, ``normal_port``,
``rich_port``, ``develop_port``,
``robot_sn`` (two letters and four digits, the version string's form, manual 2.1.3 register 1),
``admin``, ``admin_port``, ``vacuum`` (the xArm Vacuum Gripper, as ``serve --vacuum``), ``gripper``
(the device on the tool RS-485, as ``serve --gripper``: xarm, robotiq-2f85, robotiq-2f140, bio, bio-g1,
inspire-rh56),
(the version the box claims, as ``serve --firmware``), ``linear_track`` (true or a stroke in mm, as
``serve --linear-track``), ``ft_sensor`` (the six-axis F/T sensor, as
``serve --ft-sensor``), ``scene`` (a contact scene file, as ``serve --scene``), ``calibration`` (a
calibration file, as ``serve --calibration``), ``trace``
and ``faults`` (a command trace file and a fault schedule, as ``serve --trace`` and ``--faults``;
relative to the fleet file; ``faults`` may be a top-level default). Arms
without ``robot_sn`` get their model's default serial number, counted up when an earlier arm has
it, so that no two arms share a saved configuration.
Everything is checked before any port is opened; a bad file gives one message naming the file, the
arm and the key (the TOML files' one format, :mod:`xarm_emu.tomlfile`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..controller.devices.linear_track import DEFAULT_LENGTH, MODELS
from ..controller.emulator import GRIPPERS, Emulator, check_firmware
from ..controller.scene import contact
from ..model.calibration import Calibration, load
from ..model.robots import MODEL_NAMES, RobotModel, get_model, with_calibration
from ..protocol.admin import admin_host, derive_admin_port
from ..protocol.firmware import SERVE_VERSION, FirmwareProfile, VersionError, profile_for
from ..tomlfile import check_keys, load_toml
from .core import ServerConfig

_SN = re.compile(r"[A-Z]{2}[0-9]{4}")
_PORT_KEYS = ("port", "normal_port", "rich_port", "develop_port", "admin_port")
ARM_KEYS = ("model", "host", *_PORT_KEYS, "robot_sn", "admin", "vacuum", "gripper", "firmware", "trace",
            "faults", "linear_track", "ft_sensor", "scene", "calibration")
TOP_KEYS = ("speed", "config_dir", "arm", *(k for k in ARM_KEYS if k not in ("robot_sn", "trace")))


class FleetError(ValueError):
    """The fleet file cannot be used; the message says where and why."""


@dataclass(frozen=True)
class ArmSpec:
    """One arm of a fleet: its model, serial number and server configuration."""

    model: int | str  # as the file gives it: 5, 6, 7 or a name of model.robots.MODEL_NAMES
    robot_sn: str
    server: ServerConfig = field(default_factory=ServerConfig)
    vacuum: bool = False  # the xArm Vacuum Gripper on the tool IO (controller/devices/vacuum.py)
    firmware: FirmwareProfile = field(default_factory=lambda: profile_for(SERVE_VERSION))  # serve --firmware
    linear_track: int | None = None  # stroke in mm of the linear track (controller/devices/linear_track.py)
    gripper: str = "xarm"  # the gripper on the tool RS-485 (controller/emulator.py GRIPPERS)
    ft_sensor: bool = False  # the six-axis F/T sensor (controller/devices/ft_sensor.py), serve --ft-sensor
    scene: contact.Scene | None = None  # the contact scene (controller/scene/contact.py), serve --scene
    calibration: Calibration | None = None  # measured constants (model/calibration.py), serve --calibration

    def emulator(self, config_dir: Path | None) -> Emulator:
        """The box this arm describes, with its devices, saving to ``config_dir``: the one place a
        fleet arm becomes an :class:`Emulator`, in this process or in a worker."""
        model = self.model if self.calibration is None else with_calibration(get_model(self.model),
                                                                              self.calibration)
        return Emulator(model, robot_sn=self.robot_sn, config_dir=config_dir, vacuum=self.vacuum,
                        firmware=self.firmware, linear_track=self.linear_track, ft_sensor=self.ft_sensor,
                        scene=self.scene, gripper=self.gripper)


@dataclass(frozen=True)
class Fleet:
    arms: tuple[ArmSpec, ...]
    config_dir: Path | None = None


def load_fleet(path: Path) -> Fleet:
    """Read and check a fleet file (module docstring); raises :class:`FleetError` in the TOML
    files' one-line format (xarm_emu.tomlfile), naming the file."""
    return load_toml(path, "fleet file", lambda data: parse_fleet(data, base=path.parent), FleetError)


def parse_fleet(data: dict[str, Any], base: Path = Path(".")) -> Fleet:
    """Check fleet data already read from TOML; relative ``config_dir`` is taken from ``base``."""
    check_keys(data, TOP_KEYS, error=FleetError)
    arms_data = data.get("arm")
    if not isinstance(arms_data, list) or not arms_data or not all(isinstance(a, dict) for a in arms_data):
        raise FleetError("the fleet file needs at least one [[arm]] table")
    speed = data.get("speed", 1.0)
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not (math.isfinite(speed)
                                                                               and speed > 0):
        raise FleetError(f"speed must be a positive number, got {speed!r}")
    config_dir = data.get("config_dir")
    if config_dir is not None and not isinstance(config_dir, str):
        raise FleetError(f"config_dir must be a path string, got {config_dir!r}")
    defaults = {k: v for k, v in data.items() if k in ARM_KEYS}
    arms: list[ArmSpec] = []
    for i, raw in enumerate(arms_data, start=1):
        where = f"arm {i}"
        check_keys(raw, ARM_KEYS, where, FleetError)
        arms.append(_arm({**defaults, **raw}, float(speed), where, [a.robot_sn for a in arms], base))
    _distinct([a.server for a in arms])
    traces = [a.server.trace for a in arms if a.server.trace is not None]
    if len(set(traces)) != len(traces):
        raise FleetError("two arms write the same trace file")
    cdir = None if config_dir is None else (base / config_dir)
    return Fleet(tuple(arms), cdir)


def _arm(values: dict[str, Any], speed: float, where: str, taken: list[str], base: Path) -> ArmSpec:
    robot = _robot(values, where)
    host = values.get("host", "127.0.0.1")
    if not isinstance(host, str) or not host:
        raise FleetError(f"{where}: host must be an address string, got {host!r}")
    ports = _ports(values, where)
    admin, vacuum, ft_sensor = (_flag(values, key, where) for key in ("admin", "vacuum", "ft_sensor"))
    gripper = values.get("gripper", "xarm")
    if gripper not in GRIPPERS:
        raise FleetError(f"{where}: gripper is one of {', '.join(GRIPPERS)}, got {gripper!r}")
    if vacuum and "gripper" in values:
        raise FleetError(f"{where}: vacuum and gripper: one end tool at a time")
    track = _track(values, where)
    profile = _firmware(values, where)
    sn = _robot_sn(values, robot, where, taken)
    paths = _paths(values, where, base)
    cfg = replace(ServerConfig(host=host, speed=speed, admin=admin, trace=paths["trace"],
                               faults=paths["faults"]), **ports)
    try:
        check_firmware(robot, profile, gripper=gripper, vacuum=vacuum, linear_track=track,
                       ft_sensor=ft_sensor)
    except ValueError as exc:
        raise FleetError(f"{where}: {exc}") from None
    scene, calibration = _files(paths, robot, where)
    return ArmSpec(values.get("model", 6), sn, cfg, vacuum, profile, linear_track=track, gripper=gripper,
                   ft_sensor=ft_sensor, scene=scene, calibration=calibration)


def _robot(values: dict[str, Any], where: str) -> RobotModel:
    model = values.get("model", 6)
    try:
        if not isinstance(model, int | str):
            raise ValueError(model)
        return get_model(model)
    except ValueError:
        raise FleetError(f"{where}: model is one of {', '.join(MODEL_NAMES)}, got {model!r}") from None


def _ports(values: dict[str, Any], where: str) -> dict[str, Any]:
    ports: dict[str, Any] = {}
    for key in _PORT_KEYS:
        if key not in values:
            continue
        p = values[key]
        if isinstance(p, bool) or not isinstance(p, int) or not 0 <= p <= 0xFFFF:
            raise FleetError(f"{where}: {key} must be a port number 0..65535, got {p!r}")
        ports[key] = p
    return ports


def _flag(values: dict[str, Any], key: str, where: str) -> bool:
    flag = values.get(key, False)
    if not isinstance(flag, bool):
        raise FleetError(f"{where}: {key} is true or false, got {flag!r}")
    return flag


def _track(values: dict[str, Any], where: str) -> int | None:
    """The linear track's stroke in mm, or None without one."""
    track = values.get("linear_track", False)
    if track is True:
        return DEFAULT_LENGTH
    if track is False:
        return None
    if isinstance(track, bool) or not isinstance(track, int) or track not in MODELS:
        raise FleetError(f"{where}: linear_track is true or a stroke in mm "
                         f"({', '.join(map(str, MODELS))}), got {track!r}")
    return track


def _firmware(values: dict[str, Any], where: str) -> FirmwareProfile:
    firmware = values.get("firmware", SERVE_VERSION)
    if not isinstance(firmware, str):
        raise FleetError(f"{where}: firmware is a version string such as \"{SERVE_VERSION}\", "
                         f"got {firmware!r}")
    try:
        return profile_for(firmware)
    except VersionError as exc:
        raise FleetError(f"{where}: {exc}") from None


def _robot_sn(values: dict[str, Any], robot: RobotModel, where: str, taken: list[str]) -> str:
    """The arm's serial number: as given, or its model's default counted up past the ones taken."""
    sn = values.get("robot_sn")
    if sn is None:
        sn = robot.default_robot_sn
        while sn in taken:
            sn = f"{sn[:2]}{int(sn[2:]) + 1:04d}"
    elif not isinstance(sn, str) or not _SN.fullmatch(sn):
        raise FleetError(f"{where}: robot_sn is two capital letters and four digits, got {sn!r}")
    if sn in taken:
        raise FleetError(f"{where}: robot_sn {sn} is already another arm's (they would share a "
                         "saved configuration)")
    return str(sn)


def _paths(values: dict[str, Any], where: str, base: Path) -> dict[str, Path | None]:
    """The arm's files (trace, fault schedule, scene, calibration), relative to the fleet file."""
    paths: dict[str, Path | None] = {}
    for key in ("trace", "faults", "scene", "calibration"):
        value = values.get(key)
        if value is not None and not isinstance(value, str):
            raise FleetError(f"{where}: {key} must be a path string, got {value!r}")
        paths[key] = None if value is None else base / value
    return paths


def _files(paths: dict[str, Path | None], robot: RobotModel,
           where: str) -> tuple[contact.Scene | None, Calibration | None]:
    """The arm's contact scene and calibration, read from their files where it has them."""
    scene = None
    if paths["scene"] is not None:
        try:
            scene = contact.load_scene(paths["scene"])
        except ValueError as exc:
            raise FleetError(f"{where}: {exc}") from None
    calibration = None
    if paths["calibration"] is not None:
        try:
            calibration = load(paths["calibration"])
            with_calibration(robot, calibration)
        except ValueError as exc:
            raise FleetError(f"{where}: {exc}") from None
    return scene, calibration


_WILDCARD = frozenset({"", "0.0.0.0", "::"})


def _distinct(configs: list[ServerConfig]) -> None:
    """No two listeners of the fleet (within an arm or across arms) may share an address and port.
    A wildcard address (0.0.0.0, ::) takes the port on every address; the admin channel listens on
    loopback (protocol/admin.py); port 0 means any free port and never clashes."""
    seen: list[tuple[str, int, int]] = []  # (host, port, arm)
    for i, c in enumerate(configs, start=1):
        addrs = [(c.host, p) for p in (c.port, c.normal_port, c.rich_port, c.develop_port)]
        if c.admin:
            try:  # as EmulatorServer.start: port 0 gives the admin channel any free port too
                admin = c.admin_port if c.admin_port is not None else (
                    0 if c.port == 0 else derive_admin_port(c.port))
            except ValueError as exc:
                raise FleetError(f"arm {i}: {exc}") from None
            addrs.append((admin_host(c.host), admin))
        for n, (host, p) in enumerate(addrs):
            if p == 0:
                continue
            h = "127.0.0.1" if host == "localhost" else host
            for other_h, other_p, arm in seen:
                if other_p == p and (other_h == h or h in _WILDCARD or other_h in _WILDCARD):
                    hint = " (give admin_port)" if c.admin and n == len(addrs) - 1 else ""
                    owner = "this arm's too" if arm == i else f"already arm {arm}'s"
                    raise FleetError(f"arm {i}: {host}:{p} is {owner}{hint}")
            seen.append((h, p, i))
