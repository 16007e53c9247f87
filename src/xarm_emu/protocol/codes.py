"""Error and warning code tables (manual chapter 3), in our own words.

- Control box errors, section 3.2.1: "C<n>", reported in register 15's error byte and the reports.
- Control box warnings, section 3.2.2: 11-14, register 15's warning byte.
- Joint (servo) errors, section 3.1: "S<n>", per joint in register 106 and the rich report.
- Gripper errors, section 3.3: "G<n>", read from the gripper's error register over register 124; the
  Robotiq 2F-85/2F-140's faults and the BIO gripper's errors (``GRIPPER_TABLES``), also over 124.

Each entry carries a short name and what the manual tells the operator to do. ``restart`` marks codes
whose handling is a power cycle (the control box emergency-stop button) followed by re-enabling.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Code:
    code: int
    prefix: str  # "C" control box error, "W" warning, "S" servo error, "G" gripper error
    name: str
    handling: str
    restart: bool = False

    @property
    def label(self) -> str:
        return f"{self.prefix}{self.code}"

    def describe(self) -> str:
        return f"{self.label} {self.name}: {self.handling}"


_RESTART = "Power-cycle the arm with the control box emergency-stop button, then enable it again."
_SUPPORT = "Contact technical support."
_REENABLE_GRIPPER = "Enable the gripper again."


def _table(prefix: str, rows: list[tuple[int, str, str, bool]]) -> dict[int, Code]:
    return {c: Code(c, prefix, n, t, r) for c, n, t, r in rows}


#: Section 3.2.1. C10 and C11-C17 (servo of joint 1-7) come from the manual's "C11-C17: power on
#: again" row; C10 (a servo error without a joint) is the SDK's reading of the same family.
CONTROLLER_ERRORS: dict[int, Code] = _table("C", [
    (1, "Emergency stop pressed",
     "The control box emergency-stop button is pushed in. Release it, then enable the arm.", True),
    (10, "Servo error", "A joint servo reports an error. " + _RESTART, True),
    *[(10 + j, f"Servo error on joint {j}",
       f"Joint {j}'s servo reports an error (see its S code, register 106). " + _RESTART, True)
      for j in range(1, 8)],
    (19, "Gripper communication error",
     "Check that the gripper is fitted and connected correctly, or power-cycle with the emergency-stop "
     "button.", True),
    (21, "Kinematics error", "No valid kinematic solution: plan the path again.", False),
    (22, "Self-collision", "The path would make the arm hit itself. Plan the path again; if it keeps "
     "happening, switch to manual mode and move the arm back to a normal posture by hand.", False),
    (23, "Joint angle beyond limit", "A joint would leave its range. Return to the zero position.", False),
    (24, "Speed beyond limit", "Check whether the arm is near a singularity, or lower the speed and "
     "acceleration.", False),
    (25, "Planning error", "Plan the path again or lower the speed.", False),
    (26, "Linux RT error", _SUPPORT, False),
    (27, "Command reply error", "Retry, or power-cycle with the emergency-stop button.", False),
    (28, "End module communication error", _RESTART, True),
    (29, "Other error", _SUPPORT, False),
    (30, "Feedback speed beyond limit", _SUPPORT, False),
    (31, "Collision caused abnormal current", "Check for a collision, that the payload settings are "
     "right, and that the collision sensitivity suits the speed.", False),
    (32, "Three-point circle calculation error", "Send the arc command again with other points.", False),
    (33, "Control box GPIO error", "If it happens again, contact technical support.", False),
    (34, "Recording timeout", "A trajectory recording ran past its 5-minute limit; record it again.", False),
    (35, "Safety boundary limit", "The arm reached the safety boundary; keep it working inside the "
     "boundary.", False),
    (36, "Too many delayed IO commands", "At most 36 delayed or position-triggered IO commands may be "
     "pending; send fewer.", False),
    (37, "Abnormal motion in manual mode", "Check that the TCP payload and the mounting settings match "
     "the real arm.", False),
])

#: Section 3.2.2. A warning sets 0x20 in replies and changes nothing else.
WARNINGS: dict[int, Code] = _table("W", [
    (11, "Buffer overflow", "Too many commands queued: send fewer at a time.", False),
    (12, "Command parameter abnormal", "Check the parameters of the command sent.", False),
    (13, "Unknown command", "Check the register of the command sent.", False),
    (14, "Command has no solution", "Check the command sent (for example an unreachable target).", False),
])

#: Section 3.1. Joint servo error codes, shown per joint as S<code>.
SERVO_ERRORS: dict[int, Code] = _table("S", [
    (10, "Current detection error", _RESTART, True),
    (11, "Joint overcurrent", _RESTART, True),
    (12, "Joint overspeed", _RESTART, True),
    (14, "Position command beyond limit", _RESTART, True),
    (15, "Joint overheat", "After long running, stop and let the arm cool down, then restart it.", True),
    (16, "Encoder initialisation error", "Make sure nothing pushes the arm while it powers up. "
     + _RESTART, True),
    (17, "Single-turn encoder error", "Enable the arm again.", False),
    (18, "Multi-turn encoder error", _SUPPORT, True),
    (19, "Low battery voltage", _SUPPORT, True),
    (20, "Driver IC hardware error", "Enable the arm again.", False),
    (21, "Driver IC initialisation error", _RESTART, True),
    (22, "Encoder configuration error", _SUPPORT, True),
    (23, "Large motor position deviation", "Check whether the motion is blocked, the payload is within "
     "the rating, and the acceleration is not too high.", False),
    (26, "Joint positive overrun", "The joint angle is too large; check it.", False),
    (27, "Joint negative overrun", "The joint angle is too large: clear the error, release the joint "
     "by hand and turn it back into its range.", False),
    (28, "Joint command error", "The arm is not enabled: enable it.", False),
    (33, "Drive overloaded", "Keep the payload within the rated load.", False),
    (34, "Motor overload", "Keep the payload within the rated load.", False),
    (35, "Motor type error", _RESTART, True),
    (36, "Driver type error", _RESTART, True),
    (39, "Joint overvoltage", "Lower the acceleration in the motion settings.", False),
    (40, "Joint undervoltage", "Lower the acceleration in the motion settings, and check that the "
     "control box emergency-stop switch is released.", False),
    (49, "EEPROM read/write error", _RESTART, True),
    (52, "Motor angle initialisation error", _RESTART, True),
])

#: Section 3.3. xArm gripper error codes (the gripper's error register).
GRIPPER_ERRORS: dict[int, Code] = _table("G", [
    (9, "Gripper current detection error", _RESTART, True),
    (11, "Gripper current beyond limit", _REENABLE_GRIPPER, False),
    (12, "Gripper speed beyond limit", _REENABLE_GRIPPER, False),
    (14, "Gripper position command beyond limit", _REENABLE_GRIPPER, False),
    (15, "Gripper EEPROM read/write error", _REENABLE_GRIPPER, False),
    (20, "Gripper driver IC hardware error", _REENABLE_GRIPPER, False),
    (21, "Gripper driver IC initialisation error", _REENABLE_GRIPPER, False),
    (23, "Gripper large motor position deviation", "Check whether the gripper is blocked; if not, "
     "enable the gripper again.", False),
    (25, "Gripper command beyond software limit", "Check that the gripper command is within the "
     "software limits.", False),
    (26, "Gripper feedback position beyond software limit", _SUPPORT, False),
    (33, "Gripper drive overloaded", _SUPPORT, False),
    (34, "Gripper motor overload", _SUPPORT, False),
    (36, "Gripper driver type error", _REENABLE_GRIPPER, False),
])

#: The Robotiq 2F-85/2F-140's fault codes (gFLT, the low nibble of its FAULT STATUS byte), as
#: Robotiq's instruction manual lists them; 5-9 are minor faults, 10-15 major ones, which need a
#: reset (rACT cleared) and a new activation. Not in the control box manual: the SDK reads them over
#: register 124.
ROBOTIQ_FAULTS: dict[int, Code] = _table("G", [
    (5, "Action delayed: the activation must complete first", "Wait for the activation to end.", False),
    (7, "The activation bit must be set before any action", "Activate the gripper first.", False),
    (8, "Maximum operating temperature exceeded", "Wait for the gripper to cool down.", False),
    (9, "No communication for at least one second", "Check the RS-485 link.", False),
    (10, "Under minimum operating voltage", "Reset and activate the gripper again.", False),
    (11, "Automatic release in progress", "Reset and activate the gripper again.", False),
    (12, "Internal fault", "Reset and activate the gripper again; if it persists, contact support.", False),
    (13, "Activation fault", "Check that nothing blocks the fingers, then reset and activate again.",
     False),
    (14, "Overcurrent triggered", "Reset and activate the gripper again.", False),
    (15, "Automatic release completed", "Reset and activate the gripper again.", False),
])

#: The BIO gripper's error codes (its error register, 0x000F), as the SDK's code list gives them.
BIO_GRIPPER_ERRORS: dict[int, Code] = _table("G", [
    (11, "BIO gripper current beyond limit", "Clear the error and enable the gripper again.", False),
    (12, "The object slipped from the BIO gripper", "Clear the error and grip again.", False),
])

#: The error table of each end gripper the emulator attaches (``serve --gripper``).
GRIPPER_TABLES: dict[str, dict[int, Code]] = {
    "xarm": GRIPPER_ERRORS, "robotiq-2f85": ROBOTIQ_FAULTS, "robotiq-2f140": ROBOTIQ_FAULTS,
    "bio": BIO_GRIPPER_ERRORS,
    "bio-g1": BIO_GRIPPER_ERRORS,
}

_TABLES: dict[str, dict[int, Code]] = {
    "C": CONTROLLER_ERRORS, "W": WARNINGS, "S": SERVO_ERRORS, "G": GRIPPER_ERRORS,
}

#: Section 3.2.1's rule for control box codes the table does not list.
UNLISTED_HANDLING = "Not listed in the manual: power the arm on again; if it persists, contact support."


def lookup(prefix: str, code: int) -> Code | None:
    """The entry for ``code`` in the table named by ``prefix`` (C, W, S or G), or None."""
    table = _TABLES.get(prefix.upper())
    return None if table is None else table.get(code)


def controller_error(code: int) -> Code | None:
    return CONTROLLER_ERRORS.get(code)


def warning(code: int) -> Code | None:
    return WARNINGS.get(code)


def servo_error(code: int) -> Code | None:
    return SERVO_ERRORS.get(code)


def gripper_error(code: int) -> Code | None:
    return GRIPPER_ERRORS.get(code)


def _describe(prefix: str, code: int, none: str, fallback: str) -> str:
    if code == 0:
        return none
    entry = lookup(prefix, code)
    return entry.describe() if entry else f"{prefix}{code} unknown code: {fallback}"


def describe_error(code: int) -> str:
    """One line for a control box error code (register 15's error byte); 0 means none."""
    return _describe("C", code, "no error", UNLISTED_HANDLING)


def describe_warning(code: int) -> str:
    return _describe("W", code, "no warning", "not listed in the manual.")


def describe_servo_error(code: int) -> str:
    return _describe("S", code, "no servo error", "not listed in the manual; " + _RESTART.lower())


def describe_gripper_error(code: int) -> str:
    return _describe("G", code, "no gripper error", "not listed in the manual; " + _SUPPORT.lower())


def parse_label(label: str) -> Code:
    """Parse 'C31', 'W11', 'S23' or 'G11' (case-insensitive) into its table entry.

    Raises ValueError for a malformed label or a code the manual does not list (the CLI's
    fault injection refuses those).
    """
    text = label.strip().upper()
    if len(text) < 2 or text[0] not in _TABLES or not text[1:].isdigit():
        raise ValueError(f"not an error label: {label!r} (expected C<n>, W<n>, S<n> or G<n>)")
    entry = lookup(text[0], int(text[1:]))
    if entry is None:
        raise ValueError(f"{text} is not in the manual's code tables")
    return entry
