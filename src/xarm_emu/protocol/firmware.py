"""Firmware profiles: the claimed version and what the box and the SDK change for it.

The version is the last part of register 1's string ('<axis>,<type>,<robot SN>,<box SN>,vX.Y.Z',
section 2.1.3.2). The SDK compares (major, minor, revision) as integer tuples, so revisions past
100 are real releases (2.7.1 is below 2.7.100).

This module is the one home of every version threshold but a register's own: a register's ``since``
is in the register table (protocol/registers.py), which names a release of :data:`RELEASES` where
the register comes with one of its behaviours. :data:`RELEASES` states each threshold once; a
:class:`FirmwareProfile` property per behaviour answers it for a version, and every version
comparison of the package happens here (and in the register table's ``since``). A new threshold is
one entry in :data:`RELEASES` and, where code asks about it, a property; a new profile is one entry
in :data:`SUPPORTED_VERSIONS` (the CLI's choices, the register table, the reports follow from it).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property, total_ordering
from types import MappingProxyType

_VERSION = re.compile(r"^\s*[vV]?(\d{1,4})\.(\d{1,4})\.(\d{1,4})\s*$")


class VersionError(ValueError):
    """Text that is not a firmware version such as '1.6.0' or 'v2.4.101'."""


class FirmwareRefusal(ValueError):
    """A box of this firmware cannot have the part asked for (:meth:`FirmwareProfile.check_parts`)."""


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


#: Manual V1.6.0's box: the register table's :data:`~.registers.REGISTERS` and its report frames.
DEFAULT_VERSION = "1.6.0"

#: What each release brings that the emulator tells apart, oldest first: each threshold written once,
#: as the behaviours that begin with it (the SDK's ``version_is_ge`` tests and the firmware its API
#: documents for a call). A behaviour is a :class:`FirmwareProfile` property of that name, a part of
#: :data:`PARTS`, or the ``since`` of registers that come with it (``registers.py`` reads
#: :func:`first`).
RELEASES: Mapping[str, tuple[str, ...]] = MappingProxyType({
    # register 64 carries (times, speed factor), else times only (SDK playback_trajectory)
    "1.2.11": ("play_traj_speed",),
    # registers 81/82 may end with an fp32 duration; the linear motor's calls and load
    # identification (register 204) are documented from this release
    "1.8.0": ("velocity_duration", "linear_track", "load_identification"),
    # the F/T sensor: registers 200-212 (get_ft_sensor_data reads 150 below)
    "1.8.3": ("ft_sensor",),
    # the 'common' forms of 21 and 27, the only-check byte of 23/24/25 with 3-byte replies
    "1.11.100": ("common_move_layout",),
    # the 2.x controllers: their report frames (135/145/587 bytes), online planning (modes 6 and 7),
    # the D-H parameters (registers 67/68)
    "2.0.0": ("reports_2x", "online_modes", "dh_parameters"),
    # registers 253/254 and the unsolicited 0xFF feedback frames; register 36 (the payload) waits its
    # turn in the command buffer, its TRIGGER feedback sent when applied
    "2.0.102": ("feedback", "payload_queued"),
    # the real-time report on port 30000; the first firmware of the UFACTORY 850
    "2.1.0": ("realtime_report", "uf850"),
    # the first firmware of the xArm 7T
    "2.4.0": ("xarm7t",),
    # +inf in registers 21/23/83 means 'keep this component'; registers 127/134/135/136 end with a
    # sync byte (1 queued, 0 immediate)
    "2.4.101": ("inf_unchanged", "io_sync_byte"),
})

def first(behaviour: str) -> str:
    """The first version with ``behaviour`` (one of :data:`RELEASES`); KeyError for an unknown name."""
    for version, behaviours in RELEASES.items():
        if behaviour in behaviours:
            return version
    raise KeyError(f"no release of firmware.RELEASES has {behaviour!r}")


#: The parts a box can be built with that a firmware may be unable to drive, by the name a refusal
#: gives them, each with its behaviour of :data:`RELEASES`. Every other part (the xArm, Robotiq, BIO
#: and Inspire grippers on the tool RS-485, register 124 of the manual; the vacuum and Lite 6
#: grippers on the tool IO; the arms of the manual) every firmware drives.
PARTS: Mapping[str, str] = MappingProxyType({
    "linear track": "linear_track",
    "F/T sensor": "ft_sensor",
    "850 arm": "uf850",
    "xArm7T arm": "xarm7t",
})


@dataclass(frozen=True)
class FirmwareProfile:
    """What a box claiming ``version`` answers: one property per behaviour of :data:`RELEASES` that
    code asks about.

    Build one with :meth:`for_version`; every property follows from the version.
    """

    version: FirmwareVersion

    @classmethod
    def for_version(cls, version: str | FirmwareVersion) -> FirmwareProfile:
        v = version if isinstance(version, FirmwareVersion) else FirmwareVersion.parse(version)
        return cls(v)

    def _has(self, behaviour: str) -> bool:
        return self.version >= FirmwareVersion.parse(first(behaviour))

    def check_parts(self, *parts: str) -> None:
        """The one rule for the parts of a box (its arm and devices, by the names of :data:`PARTS`):
        raise :class:`FirmwareRefusal` with one line, the same for every part ('the linear track
        needs firmware 1.8.0 or later, not 1.6.0'), for the first this firmware cannot drive. A part
        :data:`PARTS` does not name every firmware drives."""
        for part in parts:
            behaviour = PARTS.get(part)
            if behaviour is not None and not self._has(behaviour):
                raise FirmwareRefusal(f"the {part} needs firmware {first(behaviour)} or later, "
                                      f"not {self.version}")

    # ---- the behaviours code asks about, oldest first (each worked out once per profile) --------
    @cached_property
    def play_traj_speed(self) -> bool:
        """Register 64 carries (times, speed factor), else times only."""
        return self._has("play_traj_speed")

    @cached_property
    def velocity_duration(self) -> bool:
        """Registers 81/82 may end with an fp32 duration."""
        return self._has("velocity_duration")

    @cached_property
    def ft_data_register(self) -> int:
        """The register get_ft_sensor_data reads: 200 with the F/T sensor's registers, 150 below."""
        return 200 if self._has("ft_sensor") else 150

    @cached_property
    def common_move_layout(self) -> bool:
        """Register 21 (43/44 bytes) and 27 (67 bytes) 'common' forms, 23/24/25 with an only-check
        byte, 3-byte replies; registers 22, 28 and 92 are no longer sent."""
        return self._has("common_move_layout")

    @cached_property
    def reports_2x(self) -> bool:
        """The report frames of the 2.x controllers (develop 135, normal 145, rich 587 bytes) with
        their fields beyond the manual's; the manual's frames below."""
        return self._has("reports_2x")

    @cached_property
    def online_modes(self) -> bool:
        """Modes 6 and 7 of register 19 (online trajectory planning)."""
        return self._has("online_modes")

    @cached_property
    def feedback(self) -> bool:
        """Registers 253/254 and unsolicited 0xFF feedback frames."""
        return self._has("feedback")

    @cached_property
    def payload_queued(self) -> bool:
        """Register 36 (the payload) waits its turn in the command buffer, and the SDK waits for its
        TRIGGER feedback; before, the payload applies when the command arrives."""
        return self._has("payload_queued")

    @cached_property
    def realtime_report(self) -> bool:
        """The real-time report on port 30000."""
        return self._has("realtime_report")

    @cached_property
    def inf_unchanged(self) -> bool:
        """+inf in registers 21/23/83 means 'keep this component'."""
        return self._has("inf_unchanged")

    @cached_property
    def io_sync_byte(self) -> bool:
        """Registers 127/134/135/136 end with a sync byte (1 queued, 0 immediate)."""
        return self._has("io_sync_byte")

    def __str__(self) -> str:
        return str(self.version)


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
