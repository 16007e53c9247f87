"""Firmware profiles: the claimed version and what the SDK changes on the wire for it.

The version is the last part of register 1's string ('<axis>,<type>,<robot SN>,<box SN>,vX.Y.Z',
section 2.1.3.2). The SDK compares (major, minor, revision) as integer tuples, so revisions past
100 are real releases (2.7.1 is below 2.7.100). A :class:`FirmwareProfile` is pure data: one
named property per behaviour the SDK ties to a version threshold.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import total_ordering

_VERSION = re.compile(r"^\s*[vV]?(\d{1,4})\.(\d{1,4})\.(\d{1,4})\s*$")


class VersionError(ValueError):
    """Text that is not a firmware version such as '1.6.0' or 'v2.4.101'."""


@total_ordering
@dataclass(frozen=True, slots=True)
class FirmwareVersion:
    """A firmware version, ordered as the SDK orders it (integer tuple compare)."""

    major: int
    minor: int
    revision: int

    @classmethod
    def parse(cls, text: str) -> FirmwareVersion:
        """'1.6.0', 'v2.4.101' or 'V2.7.1'; anything else raises :class:`VersionError`."""
        m = _VERSION.match(text) if isinstance(text, str) else None
        if m is None:
            raise VersionError(f"not a firmware version: {text!r} (expected e.g. 1.6.0 or v2.7.1)")
        return cls(int(m[1]), int(m[2]), int(m[3]))

    def __post_init__(self) -> None:
        if self.major > 9:
            # The SDK's register-1 pattern keeps only the last digit of the major.
            raise VersionError(f"major version {self.major} cannot be read by the SDK (0-9)")
        if min(self.major, self.minor, self.revision) < 0:
            raise VersionError("version parts must not be negative")

    @property
    def parts(self) -> tuple[int, int, int]:
        return (self.major, self.minor, self.revision)

    def __lt__(self, other: object) -> bool:
        if not isinstance(other, FirmwareVersion):
            return NotImplemented
        return self.parts < other.parts

    def at_least(self, text: str) -> bool:
        return self >= FirmwareVersion.parse(text)

    def __str__(self) -> str:
        return f"{self.major}.{self.minor}.{self.revision}"


def parse_version(text: str) -> FirmwareVersion:
    return FirmwareVersion.parse(text)


def _ge(v: FirmwareVersion, threshold: str) -> bool:
    return v >= FirmwareVersion.parse(threshold)


@dataclass(frozen=True)
class FirmwareProfile:
    """What a box claiming ``version`` answers, one property per SDK version threshold.

    Build one with :meth:`for_version`; every property follows from the version.
    """

    version: FirmwareVersion

    @classmethod
    def for_version(cls, version: str | FirmwareVersion) -> FirmwareProfile:
        v = version if isinstance(version, FirmwareVersion) else FirmwareVersion.parse(version)
        return cls(v)

    def _ge(self, threshold: str) -> bool:
        return _ge(self.version, threshold)

    # ---- thresholds, oldest first -------------------------------------------------------------
    @property
    def load_center_mm(self) -> bool:
        """>= 0.2.1: the payload centre of mass (register 36, normal report) is in mm."""
        return self._ge("0.2.1")

    @property
    def reduced_state_size(self) -> int:
        """Register 53's reply: 79 bytes from 1.2.11, 21 below."""
        return 79 if self._ge("1.2.11") else 21

    @property
    def play_traj_speed(self) -> bool:
        """>= 1.2.11: register 64 carries (times, speed factor), else times only."""
        return self._ge("1.2.11")

    @property
    def blended_joint_register(self) -> bool:
        """>= 1.5.20: blended joint moves use register 24 (7 joints, speed, acc, radius)."""
        return self._ge("1.5.20")

    @property
    def velocity_duration(self) -> bool:
        """>= 1.8.0: registers 81/82 may end with an fp32 duration."""
        return self._ge("1.8.0")

    @property
    def ft_data_register(self) -> int:
        """F/T data register: 200 from 1.8.3, 150 below."""
        return 200 if self._ge("1.8.3") else 150

    @property
    def protocol_v3(self) -> bool:
        """>= 1.8.6: the SDK switches its command frames to protocol id 3 (heartbeat form)."""
        return self._ge("1.8.6")

    @property
    def relative_move_register(self) -> bool:
        """>= 1.8.100: relative moves use register 83 (MOVE_RELATIVE)."""
        return self._ge("1.8.100")

    @property
    def joint_states_num(self) -> bool:
        """>= 1.9.110: register 42 carries a [num] byte (blocks of 7 fp32 in the reply)."""
        return self._ge("1.9.110")

    @property
    def set_mode_detection(self) -> bool:
        """>= 1.10.0: register 19 carries [mode, detection_param]."""
        return self._ge("1.10.0")

    @property
    def common_move_layout(self) -> bool:
        """>= 1.11.100: register 21 (43/44 bytes) and 27 (67 bytes) 'common' forms, 3-byte replies;
        registers 22, 28 and 92 are no longer sent."""
        return self._ge("1.11.100")

    @property
    def feedback(self) -> bool:
        """>= 2.0.102: registers 253/254 and unsolicited 0xFF feedback frames."""
        return self._ge("2.0.102")

    @property
    def payload_queued(self) -> bool:
        """>= 2.0.102: register 36 (the payload) waits its turn in the command buffer, and the SDK
        waits for its TRIGGER feedback; below, the payload applies when the command arrives."""
        return self._ge("2.0.102")

    @property
    def inf_unchanged(self) -> bool:
        """>= 2.4.101: +inf in registers 21/23/83 means 'keep this component'."""
        return self._ge("2.4.101")

    @property
    def io_sync_byte(self) -> bool:
        """>= 2.4.101: registers 127/134/135/136 end with a sync byte (1 queued, 0 immediate)."""
        return self._ge("2.4.101")

    @property
    def joint_states_high_nibble(self) -> bool:
        """>= 2.6.107: register 42's num byte keeps its high nibble."""
        return self._ge("2.6.107")

    @property
    def ft_raw_data(self) -> bool:
        """>= 2.6.109: register 200 [01] asks for raw F/T data."""
        return self._ge("2.6.109")

    @property
    def servo_error_u16(self) -> bool:
        """>= 2.7.100: the F/T error read (register 102) is the u16 in reply bytes 2..3."""
        return self._ge("2.7.100")

    @property
    def ik_limited(self) -> bool:
        """>= 2.7.103: register 43 may end with [limited] and 7 reference angles."""
        return self._ge("2.7.103")

    @property
    def rich_report_size(self) -> int:
        """Rich report (port 30002) length: 587 bytes for 2.x, the manual's 433 below."""
        return 587 if self.version.major >= 2 else 433

    @property
    def develop_report_size(self) -> int:
        """Develop report (port 30003) length: 135 bytes (F/T tail) for 2.x, 87 below."""
        return 135 if self.version.major >= 2 else 87

    @property
    def realtime_report(self) -> bool:
        """>= 2.1.0: the real-time report on port 30000."""
        return self._ge("2.1.0")

    @property
    def is_v1(self) -> bool:
        return self.version.major < 2

    def version_text(self, axis: int, robot_type: int, robot_sn: str, box_sn: str) -> str:
        """Register 1's string (before NUL padding to 40 bytes): '<axis>,<type>,<SN6>,<SN6>,vX.Y.Z'."""
        return f"{axis},{robot_type},{robot_sn[:6]},{box_sn[:6]},v{self.version}"

    def __str__(self) -> str:
        return str(self.version)


#: Manual V1.6.0: today's behaviour.
DEFAULT_VERSION = "1.6.0"
DEFAULT_PROFILE = FirmwareProfile.for_version(DEFAULT_VERSION)

#: Versions the CLI accepts for --firmware (1.6.0 first; the newest last).
SUPPORTED_VERSIONS: tuple[str, ...] = ("1.6.0", "1.11.100", "2.0.102", "2.4.101", "2.6.110", "2.7.1",
                                       "2.7.103")
NEWEST_PROFILE = FirmwareProfile.for_version(SUPPORTED_VERSIONS[-1])

#: What ``xarm-emu serve`` (and a fleet arm, and ``xarm-emu replay``) claims unless told: the newest
#: firmware, as arms sold today run 2.x. The official SDK's example programs run against it at least
#: as well as against 1.6.0 (several only there). The in-process ``Emulator`` and
#: ``xarm_emu.testing.running_emulator`` keep :data:`DEFAULT_VERSION`, the manual's box, whose byte
#: examples they reproduce.
SERVE_VERSION = SUPPORTED_VERSIONS[-1]


def profile_for(version: str) -> FirmwareProfile:
    """The profile of a CLI version, refusing versions not in :data:`SUPPORTED_VERSIONS`."""
    v = FirmwareVersion.parse(version)
    if str(v) not in SUPPORTED_VERSIONS:
        raise VersionError(f"firmware {v} not supported; choose one of {', '.join(SUPPORTED_VERSIONS)}")
    return FirmwareProfile(v)
