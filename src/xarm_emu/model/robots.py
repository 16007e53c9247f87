"""Immutable descriptions of the arms the emulator plays: xArm 5, 6 and 7, Lite 6, UFACTORY 850, xArm 7T.

Joint frames are the vendor URDF joint origins, with lengths converted to mm and the +/-1.5708 and
+/-3.1416 angles replaced by exact +/-pi/2 and +/-pi (the xArm 7T uses the vendor's mirrored xArm 7
origins). Each joint turns about its local z axis after the fixed origin
transform ``Trans(xyz) . Rz(yaw) Ry(pitch) Rx(roll)``; the flange (default TCP) is the frame after the
last joint.

Joint limits are those the SDK checks for each (axis, type) of its joint limit tables, which for the xArm
are the radian forms of the manual's tables (manual 1.3 Table 1.1, 4.2-4.4). The Cartesian range is the
manual's (4.1) for the xArm and the SDK's TCP table for Lite 6 and 850.

Identity (manual 2.2 register 1, "axis,type,robot SN,box SN,version"; register 8): ``axis`` and
``robot_type`` are what the control box reports; ``sn_prefix`` is the first two letters of the robot serial
number the SDK expects of the model (it checks them before friction identification), and
:func:`robot_sn_problem` states the SDK's rules on the four digits that follow. The first firmware
release that runs a model is protocol/firmware.py's (its ``PARTS``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .calibration import Calibration, CalibrationError

HALF_PI = math.pi / 2.0
TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class JointSpec:
    """One revolute joint: fixed origin in the parent frame (mm, rad), then rotation about local z."""

    name: str
    origin_xyz: tuple[float, float, float]
    origin_rpy: tuple[float, float, float]
    lower: float
    upper: float


@dataclass(frozen=True)
class PneumaticGripper:
    """A gripper driven by two tool outputs, (TO0, TO1) per command, with no position or status readback.

    The Lite 6 gripper: the SDK's open/close/stop commands write TO0/TO1 through register 127
    (address 0x0A15); the jaw state is whatever the last combination asked for.
    """

    open: tuple[int, int] = (1, 0)
    close: tuple[int, int] = (0, 1)
    stop: tuple[int, int] = (0, 0)

    def command(self, to0: int, to1: int) -> str | None:
        """``"open"``, ``"close"`` or ``"stop"`` for an output combination, None for one no command sets."""
        outs = (1 if to0 else 0, 1 if to1 else 0)
        for name in ("open", "close", "stop"):
            if getattr(self, name) == outs:
                return name
        return None


@dataclass(frozen=True)
class VacuumWiring:
    """Tool IO of the vacuum gripper for one hardware version: pump on/off as (first, second) output
    values, and the input that reports an object held (the SDK's ``hardware_version`` 1 and 2)."""

    outputs: tuple[str, str]
    on: tuple[int, int]
    off: tuple[int, int]
    object_input: str


#: Vacuum gripper wiring by hardware version: 1 "plug-in connection" (TO0/TO1, TI0), 2 "contact
#: connection" (TO3/TO4, TI3). The same on every model.
VACUUM_WIRING: dict[int, VacuumWiring] = {
    1: VacuumWiring(("TO0", "TO1"), (1, 0), (0, 1), "TI0"),
    2: VacuumWiring(("TO3", "TO4"), (1, 0), (0, 1), "TI3"),
}

#: Tool register (through registers 127/128) that holds TI2 in bit 0, on Lite 6 and 850 only.
TI2_ADDRESS = 0x0A12


@dataclass(frozen=True)
class ToolIO:
    """Tool-end IO differences between models.

    ``digital_inputs``: what the SDK's ``get_tool_digital_input()`` returns without an input number
    (xArm: TI0, TI1; an xArm whose robot SN digits are >= 1305 adds TI3, TI4: a serial-number rule, not a
    model one). ``ti2_address``: the tool register of TI2 (None: no TI2). ``ti2_teach_button``: TI2 is
    the tool-end button that toggles manual mode (Lite 6). ``gripper``: a gripper wired to TO0/TO1
    (Lite 6), None when the model's gripper is on the tool RS-485 (xArm Gripper).
    """

    digital_inputs: tuple[str, ...] = ("TI0", "TI1")
    ti2_address: int | None = None
    ti2_teach_button: bool = False
    gripper: PneumaticGripper | None = None


XARM_TOOL_IO = ToolIO()
LITE6_TOOL_IO = ToolIO(("TI0", "TI1", "TI2"), TI2_ADDRESS, True, PneumaticGripper())
UF850_TOOL_IO = ToolIO(("TI0", "TI1", "TI2", "TI3", "TI4"), TI2_ADDRESS)


@dataclass(frozen=True)
class RobotModel:
    """One arm model. ``axis``/``robot_type`` are what the version string and register 8 report."""

    name: str
    dof: int
    axis: int
    robot_type: int
    joints: tuple[JointSpec, ...]
    max_joint_speed: float
    zero_pose: tuple[float, float, float, float, float, float]
    # Cartesian range (manual 4.1): ((x_min, x_max), (y_min, y_max), (z_min, z_max)) in mm,
    # then roll/pitch/yaw bounds in rad.
    tcp_range: tuple[tuple[float, float], ...] = field(
        default=((-700.0, 700.0), (-700.0, 700.0), (-400.0, 951.5),
                 (-math.pi, math.pi), (-math.pi, math.pi), (-math.pi, math.pi))
    )
    # xArm5 Cartesian targets must keep the flange level: roll = +/-pi, pitch = 0 (as the SDK requires).
    fixed_roll_pitch: bool = False
    max_joint_acc: float = 20.0  # rad/s^2, manual 1.3 Table 1.2 (1145 deg/s^2)
    max_joint_jerk: float = 500.0  # rad/s^3, manual 1.3 Table 1.2 (28647 deg/s^3)
    max_tcp_speed: float = 1000.0  # mm/s, manual 1.3 Table 1.2
    max_tcp_acc: float = 50000.0  # mm/s^2
    max_tcp_jerk: float = 10000.0  # mm/s^3
    # Rated payload in kg (manual 4.2-4.4: xArm5 3 kg, xArm6 5 kg, xArm7 3.5 kg; vendor product pages:
    # Lite 6 0.6 kg, 850 5 kg). Register 36 refuses a
    # heavier payload or a centre of mass farther than ``payload_com_limit`` mm from the flange on any
    # axis; the manual gives no bound there, so this is the emulator's, wide enough for its 400 mm example.
    rated_payload: float = 5.0
    payload_com_limit: float = 1000.0
    # Short name for lookup (``get_model``) and the command line; see ``MODEL_NAMES``.
    key: str = ""
    # Reach in mm as the vendor's specifications state it (xArm 5/6/7 700, Lite 6 440, 850 850 mm).
    reach: float = 700.0
    # Identity (module docstring): robot SN prefix, default robot and control box serial numbers.
    sn_prefix: str = "XI"
    default_robot_sn: str = "XI1300"
    default_box_sn: str = "AC1300"
    tool_io: ToolIO = XARM_TOOL_IO
    # Measured replacements of the emulator's estimated constants (:func:`with_calibration`).
    calibration: Calibration | None = None

    @property
    def lower(self) -> np.ndarray:
        """Lower joint limits (rad), length ``dof``."""
        return np.array([j.lower for j in self.joints], dtype=float)

    @property
    def upper(self) -> np.ndarray:
        """Upper joint limits (rad), length ``dof``."""
        return np.array([j.upper for j in self.joints], dtype=float)

    @property
    def zero_joints(self) -> np.ndarray:
        """All-zero joint vector of length ``dof``."""
        return np.zeros(self.dof)


def with_calibration(model: RobotModel, calibration: Calibration | None) -> RobotModel:
    """``model`` with ``calibration``'s constants (a new model; ``None`` or an empty one gives ``model``);
    ``CalibrationError`` when it was measured on another model or does not fit the joints."""
    if calibration is None or calibration.empty:
        return model
    if calibration.model and calibration.model != model.key:
        raise CalibrationError(f"the calibration was measured on model {calibration.model}, not {model.key}")
    calibration.check(model.dof)
    return replace(model, calibration=calibration)


def joint_values(model: RobotModel, q: Sequence[float] | np.ndarray) -> list[float]:
    """The first ``dof`` values of ``q`` as floats (extra values, such as the wire J7 of a 6-axis arm, are
    ignored); ``ValueError`` when there are fewer than ``dof`` or one is not finite."""
    qs = q.tolist() if isinstance(q, np.ndarray) else list(map(float, q))
    dof = model.dof
    if len(qs) != dof:
        if len(qs) < dof:
            raise ValueError(f"{model.name} needs {dof} joint values, got {len(qs)}")
        qs = qs[:dof]
    # A finite sum means every value is finite (an infinity or a NaN makes the sum one); a sum that is
    # not finite (a value is not, or finite values overflow) is looked into value by value.
    if not math.isfinite(sum(qs)):
        for v in qs:
            if not math.isfinite(v):
                raise ValueError(f"non-finite joint value {v!r}")
    return qs


def _j(name: str, xyz: tuple[float, float, float], roll: float, lo: float, hi: float,
       pitch: float = 0.0, yaw: float = 0.0) -> JointSpec:
    return JointSpec(name, (float(xyz[0]), float(xyz[1]), float(xyz[2])), (roll, pitch, yaw), lo, hi)


# Limits in rad (the SDK's values; manual 1.3: +/-360, -118..120, -225..11, -97..180, -11..225 degrees).
_FULL = (-TWO_PI, TWO_PI)
_SHOULDER = (-2.059488, 2.094395)
_ELBOW = (-3.92699, 0.191986)
_ELBOW7 = (-0.191986, 3.92699)
_WRIST = (-1.692969, math.pi)

XARM5 = RobotModel(
    name="xArm5",
    dof=5,
    axis=5,
    robot_type=5,
    joints=(
        _j("joint1", (0, 0, 267), 0.0, *_FULL),
        _j("joint2", (0, 0, 0), -HALF_PI, *_SHOULDER),
        _j("joint3", (53.5, -284.5, 0), 0.0, *_ELBOW),
        _j("joint4", (77.5, 342.5, 0), 0.0, *_WRIST),
        _j("joint5", (76, 97, 0), -HALF_PI, *_FULL),
    ),
    max_joint_speed=math.pi,
    zero_pose=(207.0, 0.0, 112.0, math.pi, 0.0, 0.0),
    fixed_roll_pitch=True,
    rated_payload=3.0,
    key="5",
    sn_prefix="XF",
    default_robot_sn="XF1300",
)

XARM6 = RobotModel(
    name="xArm6",
    dof=6,
    axis=6,
    robot_type=6,
    joints=(
        _j("joint1", (0, 0, 267), 0.0, *_FULL),
        _j("joint2", (0, 0, 0), -HALF_PI, *_SHOULDER),
        _j("joint3", (53.5, -284.5, 0), 0.0, *_ELBOW),
        _j("joint4", (77.5, 342.5, 0), -HALF_PI, *_FULL),
        _j("joint5", (0, 0, 0), HALF_PI, *_WRIST),
        _j("joint6", (76, 97, 0), -HALF_PI, *_FULL),
    ),
    max_joint_speed=math.pi,
    zero_pose=(207.0, 0.0, 112.0, math.pi, 0.0, 0.0),
    key="6",
)

XARM7 = RobotModel(
    name="xArm7",
    dof=7,
    axis=7,
    robot_type=7,
    joints=(
        _j("joint1", (0, 0, 267), 0.0, *_FULL),
        _j("joint2", (0, 0, 0), -HALF_PI, *_SHOULDER),
        _j("joint3", (0, -293, 0), HALF_PI, *_FULL),
        _j("joint4", (52.5, 0, 0), HALF_PI, *_ELBOW7),
        _j("joint5", (77.5, -342.5, 0), HALF_PI, *_FULL),
        _j("joint6", (0, 0, 0), HALF_PI, *_WRIST),
        _j("joint7", (76, 97, 0), -HALF_PI, *_FULL),
    ),
    max_joint_speed=math.pi,
    zero_pose=(206.0, 0.0, 120.5, math.pi, 0.0, 0.0),
    rated_payload=3.5,
    key="7",
    sn_prefix="XS",
    default_robot_sn="XS1300",
)

# Lite 6 (axis 6, type 9). Limits: J2 +/-150, J3 -3.5..300, J5 +/-124 degrees (the SDK's type 9 table).
# TCP speed 0..500 mm/s (vendor specification); payload 0.6 kg and reach 440 mm (vendor product page).
LITE6 = RobotModel(
    name="Lite6",
    dof=6,
    axis=6,
    robot_type=9,
    joints=(
        _j("joint1", (0, 0, 243.5), 0.0, *_FULL),
        _j("joint2", (0, 0, 0), HALF_PI, -2.6179938779914944, 2.6179938779914944, -HALF_PI, math.pi),
        _j("joint3", (200.2, 0, 0), -math.pi, -0.061086523819801536, 5.235987755982989, 0.0, HALF_PI),
        _j("joint4", (87, -227.61, 0), HALF_PI, *_FULL),
        _j("joint5", (0, 0, 0), HALF_PI, -2.1642082724729685, 2.1642082724729685),
        _j("joint6", (0, 62.5, 0), -HALF_PI, *_FULL),
    ),
    max_joint_speed=math.pi,
    zero_pose=(87.0, 0.0, 153.59, math.pi, 0.0, 0.0),
    tcp_range=((-500.0, 500.0), (-500.0, 500.0), (-150.0, 750.0),
               (-math.pi, math.pi), (-math.pi, math.pi), (-math.pi, math.pi)),
    max_tcp_speed=500.0,
    rated_payload=0.6,
    key="lite6",
    reach=440.0,
    sn_prefix="LI",
    default_robot_sn="LI1006",
    default_box_sn="DL1000",
    # No first firmware is published for the Lite 6 and the emulator enforces none.
    tool_io=LITE6_TOOL_IO,
)

# UFACTORY 850 (axis 6, type 12), the "850 arm" of firmware.PARTS (behaviour uf850). Limits: J2 +/-132, J3
# -242..3.5, J5 +/-124 degrees (the SDK's type 12 table). Payload 5 kg and reach 850 mm (vendor product page).
UF850 = RobotModel(
    name="850",
    dof=6,
    axis=6,
    robot_type=12,
    joints=(
        _j("joint1", (0, 0, 364), 0.0, *_FULL),
        _j("joint2", (0, 0, 0), HALF_PI, -2.303834612632515, 2.303834612632515, -HALF_PI, 0.0),
        _j("joint3", (390, 0, 0), -math.pi, -4.223696789826278, 0.061086523819801536, 0.0, -HALF_PI),
        _j("joint4", (150, 426, 0), -HALF_PI, *_FULL),
        _j("joint5", (0, 0, 0), -HALF_PI, -2.1642082724729685, 2.1642082724729685),
        _j("joint6", (0, -90, 0), HALF_PI, *_FULL),
    ),
    max_joint_speed=math.pi,
    zero_pose=(150.0, 0.0, 238.0, math.pi, 0.0, 0.0),
    tcp_range=((-1000.0, 1000.0), (-1000.0, 1000.0), (-400.0, 1300.0),
               (-math.pi, math.pi), (-math.pi, math.pi), (-math.pi, math.pi)),
    rated_payload=5.0,
    key="850",
    reach=850.0,
    sn_prefix="FX",
    default_robot_sn="FX1202",
    tool_io=UF850_TOOL_IO,
)

# xArm 7T (axis 7, type 13), the "xArm7T arm" of firmware.PARTS (behaviour xarm7t): its J2, J4 and J6 ranges
# are the xArm 7's with their signs swapped (the SDK's type 13 table). The vendor publishes no 7T joint
# origins; the emulator takes those of the vendor's mirrored xArm 7 (rolls of the opposite sign, calibrated
# lengths), which match those ranges. Payload and reach as the xArm 7.
XARM7T = RobotModel(
    name="xArm7T",
    dof=7,
    axis=7,
    robot_type=13,
    joints=(
        _j("joint1", (-0.52471, 0, 266.8), 0.0, *_FULL),
        _j("joint2", (0, 0, 0), HALF_PI, -_SHOULDER[1], -_SHOULDER[0]),
        _j("joint3", (0, 292.89, 0), -HALF_PI, *_FULL),
        _j("joint4", (52.665, 0, 0), -HALF_PI, *_ELBOW),
        _j("joint5", (77.699, 342.58, 0), -HALF_PI, *_FULL),
        _j("joint6", (0, 0, 0), -HALF_PI, -math.pi, -_WRIST[0]),
        _j("joint7", (75.998, -96.156, 0), HALF_PI, *_FULL),
    ),
    max_joint_speed=math.pi,
    zero_pose=(205.83729, 0.0, 120.954, math.pi, 0.0, 0.0),
    rated_payload=3.5,
    key="7t",
    sn_prefix="CS",
    default_robot_sn="CS1300",
)

MODELS: dict[int, RobotModel] = {5: XARM5, 6: XARM6, 7: XARM7}

#: Every model by its short name, in the order of ``MODEL_NAMES``.
ROBOT_MODELS: dict[str, RobotModel] = {m.key: m for m in (XARM5, XARM6, XARM7, LITE6, UF850, XARM7T)}

#: The short names ``get_model`` knows (for the command line's help).
MODEL_NAMES: tuple[str, ...] = tuple(ROBOT_MODELS)

# Longer spellings: "xarm6", "xArm 7T", "uf850", "UFACTORY 850", "Lite 6", "lite-6".
_ALIASES: dict[str, str] = {
    **{f"xarm{k}": k for k in ("5", "6", "7", "7t")},
    "uf850": "850", "ufactory850": "850", "xarmlite6": "lite6", "ufactorylite6": "lite6",
}


def _normal(name: str) -> str:
    return "".join(ch for ch in name.lower() if ch.isalnum())


def get_model(name: int | str) -> RobotModel:
    """The model for 5, 6 or 7 axes or a name (``MODEL_NAMES`` and longer spellings such as ``"xarm6"``,
    ``"uf850"``, ``"Lite 6"``; case, spaces, ``-`` and ``_`` do not matter); ``ValueError`` otherwise,
    with a message listing the known names."""
    if isinstance(name, str):
        key = _normal(name)
        key = _ALIASES.get(key, key)
        if key in ROBOT_MODELS:
            return ROBOT_MODELS[key]
    elif not isinstance(name, bool):
        try:
            if int(name) == name and int(name) in MODELS:  # 6, numpy integers, 6.0
                return MODELS[int(name)]
        except (TypeError, ValueError, OverflowError):
            pass
    raise ValueError(f"unknown robot model {name!r}; known: {', '.join(MODEL_NAMES)}")


def robot_sn_problem(model: RobotModel, sn: str) -> str | None:
    """Why the SDK would mistake robot serial number ``sn`` for another model, or None when it fits.

    The SDK reads the two-letter prefix (friction identification checks it against the model) and the
    four digits after it (a non-digit there makes joint moves raise; digits 1305..8499 make the SDK check
    joints against its newer xArm table of ``axis``, whatever the model, so Lite 6, 850 and xArm 7T need
    digits outside that range).
    """
    if sn[:2] != model.sn_prefix:
        return f"{model.name} robot serial numbers start with {model.sn_prefix!r}, got {sn!r}"
    digits = sn[2:6]
    if len(digits) != 4 or not digits.isdigit():
        return f"robot serial number {sn!r} needs four digits after its prefix"
    if model.key not in ("5", "6", "7") and 1305 <= int(digits) < 8500:
        return (f"robot serial number digits 1305..8499 make the SDK check joints against the xArm "
                f"{model.axis} table; {model.name} needs other digits, got {digits}")
    return None
