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
(the gripper on the tool RS-485, as ``serve --gripper``: xarm, robotiq-2f85, robotiq-2f140, bio),
(the version the box claims, as ``serve --firmware``), ``linear_track`` (true or a stroke in mm, as
``serve --linear-track``), ``ft_sensor`` (the six-axis F/T sensor, as
``serve --ft-sensor``), ``scene`` (a contact scene file, as ``serve --scene``), ``calibration`` (a
calibration file, as ``serve --calibration``), ``trace``
and ``faults`` (a command trace file and a fault schedule, as ``serve --trace`` and ``--faults``;
relative to the fleet file; ``faults`` may be a top-level default). Arms
without ``robot_sn`` get their model's default serial number, counted up when an earlier arm has
it, so that no two arms share a saved configuration.
Everything is checked before any port is opened; a bad file gives one message naming the arm and
the key.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..controller.devices.linear_track import DEFAULT_LENGTH, MODELS
from ..controller.emulator import GRIPPERS, Emulator, check_firmware
from ..controller.scene import contact
from ..model.calibration import Calibration, load
from ..model.robots import MODEL_NAMES, get_model, with_calibration
from ..protocol.admin import admin_host, derive_admin_port
from ..protocol.firmware import SERVE_VERSION, FirmwareProfile, VersionError, profile_for
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
    """Read and check a fleet file (module docstring); raises :class:`FleetError`."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise FleetError(f"cannot read the fleet file {path}: {exc.strerror or exc}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise FleetError(f"{path} is not valid TOML: {exc}") from None
    return parse_fleet(data, base=path.parent)


def parse_fleet(data: dict[str, Any], base: Path = Path(".")) -> Fleet:
    """Check fleet data already read from TOML; relative ``config_dir`` is taken from ``base``."""
    _unknown(data, TOP_KEYS, "the fleet file")
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
        _unknown(raw, ARM_KEYS, where)
        arms.append(_arm({**defaults, **raw}, float(speed), where, [a.robot_sn for a in arms], base))
    _distinct([a.server for a in arms])
    traces = [a.server.trace for a in arms if a.server.trace is not None]
    if len(set(traces)) != len(traces):
        raise FleetError("two arms write the same trace file")
    cdir = None if config_dir is None else (base / config_dir)
    return Fleet(tuple(arms), cdir)


def _unknown(table: dict[str, Any], known: tuple[str, ...], where: str) -> None:
    extra = sorted(set(table) - set(known))
    if extra:
        raise FleetError(f"{where}: unknown key {extra[0]!r}; known: {', '.join(known)}")


def _arm(values: dict[str, Any], speed: float, where: str, taken: list[str], base: Path) -> ArmSpec:
    model = values.get("model", 6)
    try:
        if not isinstance(model, int | str):
            raise ValueError(model)
        robot = get_model(model)
    except ValueError:
        raise FleetError(f"{where}: model is one of {', '.join(MODEL_NAMES)}, got {model!r}") from None
    host = values.get("host", "127.0.0.1")
    if not isinstance(host, str) or not host:
        raise FleetError(f"{where}: host must be an address string, got {host!r}")
    ports: dict[str, Any] = {}
    for key in _PORT_KEYS:
        if key not in values:
            continue
        p = values[key]
        if isinstance(p, bool) or not isinstance(p, int) or not 0 <= p <= 0xFFFF:
            raise FleetError(f"{where}: {key} must be a port number 0..65535, got {p!r}")
        ports[key] = p
    admin, vacuum = values.get("admin", False), values.get("vacuum", False)
    ft_sensor = values.get("ft_sensor", False)
    for key, flag in (("admin", admin), ("vacuum", vacuum), ("ft_sensor", ft_sensor)):
        if not isinstance(flag, bool):
            raise FleetError(f"{where}: {key} is true or false, got {flag!r}")
    gripper = values.get("gripper", "xarm")
    if gripper not in GRIPPERS:
        raise FleetError(f"{where}: gripper is one of {', '.join(GRIPPERS)}, got {gripper!r}")
    if vacuum and "gripper" in values:
        raise FleetError(f"{where}: vacuum and gripper: one end tool at a time")
    track = values.get("linear_track", False)
    if track is True:
        track = DEFAULT_LENGTH
    if track is False:
        track = None
    elif isinstance(track, bool) or not isinstance(track, int) or track not in MODELS:
        raise FleetError(f"{where}: linear_track is true or a stroke in mm "
                         f"({', '.join(map(str, MODELS))}), got {track!r}")
    firmware = values.get("firmware", SERVE_VERSION)
    if not isinstance(firmware, str):
        raise FleetError(f"{where}: firmware is a version string such as \"2.7.103\", got {firmware!r}")
    try:
        profile = profile_for(firmware)
    except VersionError as exc:
        raise FleetError(f"{where}: {exc}") from None
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
    paths: dict[str, Path | None] = {}
    for key in ("trace", "faults", "scene", "calibration"):
        value = values.get(key)
        if value is not None and not isinstance(value, str):
            raise FleetError(f"{where}: {key} must be a path string, got {value!r}")
        paths[key] = None if value is None else base / value
    cfg = replace(ServerConfig(host=host, speed=speed, admin=admin, trace=paths["trace"],
                               faults=paths["faults"]), **ports)
    try:
        check_firmware(robot, profile)
    except ValueError as exc:
        raise FleetError(f"{where}: {exc}") from None
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
    return ArmSpec(model, sn, cfg, vacuum, profile, linear_track=track, gripper=gripper, ft_sensor=ft_sensor,
                   scene=scene, calibration=calibration)


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
