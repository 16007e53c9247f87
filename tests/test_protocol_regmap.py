"""The register-map datastore of the RS-485 devices (protocol/regmap.py): how a request's addresses,
values, blocks and commits are served from a declared map, whatever the device."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest

from xarm_emu.protocol import regmap, rtu
from xarm_emu.protocol.rtu import ILLEGAL_ADDRESS, ILLEGAL_VALUE


@dataclass
class Drive:
    enabled: int = 0
    speed: int = 100
    position: float = 12.3456
    words: list[int] = field(default_factory=lambda: [0, 0])
    target: int = 0
    commits: int = 0
    moves: list[tuple[int, ...]] = field(default_factory=list)
    limits: list[int] = field(default_factory=lambda: [5, 6, 7])


def _word(d: Drive, value: int, *, word: int) -> None:
    d.words[word] = value


def _commit(d: Drive) -> None:
    d.commits += 1
    d.target = rtu.words_s32(*d.words)


def _move(d: Drive, values: tuple[int, ...]) -> None:
    d.moves.append(values)


MAP: dict[int, regmap.Reg] = {
    0x10: regmap.Reg("enabled", "rw", range=(0, 1)),
    0x11: regmap.Reg("speed", "rw", range=(1, 500), keep=0xFFFF),
    **regmap.s32(0x20, "target", access="rw", put=_word, commit=_commit),
    **regmap.s32(0x30, "position", counts=1000.0, unit="mm"),
    0x40: regmap.Reg("move", "w", put=_move, block=3),
    **regmap.items(0x50, "limits", 3, access="rw", stride=2, range=(0, 9)),
}


def test_reads_come_from_the_fields_and_a_missing_or_write_only_address_is_exception_2() -> None:
    d = Drive(enabled=1, target=-2)
    assert regmap.read_registers(MAP, d, 0x10, 2) == [1, 100]
    assert regmap.read_registers(MAP, d, 0x20, 2) == [0xFFFF, 0xFFFE]  # s32 -2, high word first
    assert regmap.read_registers(MAP, d, 0x30, 2) == list(rtu.s32_words(12346))  # mm x 1000, rounded
    assert regmap.read_registers(MAP, d, 0x50, 3, stride=2) == [5, 6, 7]
    for address, count in ((0x12, 1), (0x11, 2), (0x40, 1), (0x51, 1)):
        with pytest.raises(rtu.RtuError) as exc:
            regmap.read_registers(MAP, d, address, count)
        assert exc.value.code == ILLEGAL_ADDRESS


def test_a_write_reaching_a_missing_or_read_only_address_changes_nothing() -> None:
    d = Drive()
    for address, values in (((0x10), [1, 7, 0]), (0x30, [1]), (0x12, [1])):
        with pytest.raises(rtu.RtuError) as exc:
            regmap.write_registers(MAP, d, address, values)
        assert exc.value.code == ILLEGAL_ADDRESS
    assert d == Drive()


def test_values_are_checked_in_turn_unless_atomic() -> None:
    d = Drive()
    with pytest.raises(rtu.RtuError) as exc:
        regmap.write_registers(MAP, d, 0x10, [1, 600])
    assert exc.value.code == ILLEGAL_VALUE and d.enabled == 1 and d.speed == 100  # the first took
    d = Drive()
    with pytest.raises(rtu.RtuError):
        regmap.write_registers(MAP, d, 0x10, [1, 600], atomic=True)
    assert d == Drive()  # atomic: nothing took
    # Atomic checks each register's address, then its value, in order: a bad value before a bad
    # address is exception 3.
    with pytest.raises(rtu.RtuError) as exc:
        regmap.write_registers(MAP, d, 0x50, [10, 1, 1, 1], stride=2, atomic=True)
    assert exc.value.code == ILLEGAL_VALUE


def test_the_keep_value_leaves_the_field_and_commits_run_once_after_the_request() -> None:
    d = Drive()
    regmap.write_registers(MAP, d, 0x11, [0xFFFF])
    assert d.speed == 100
    regmap.write_registers(MAP, d, 0x20, list(rtu.s32_words(-5000)))
    assert (d.target, d.commits) == (-5000, 1)
    regmap.write_registers(MAP, d, 0x21, [0x0001])  # the low word alone: the high word kept
    assert (d.target, d.commits) == (rtu.words_s32(0xFFFF, 1), 2)


def test_a_block_is_written_whole_or_not_at_all() -> None:
    d = Drive()
    regmap.write_registers(MAP, d, 0x40, [1, 2, 3])
    assert d.moves == [(1, 2, 3)]
    for values in ([1, 2], [1, 2, 3, 4]):
        with pytest.raises(rtu.RtuError) as exc:
            regmap.write_registers(MAP, d, 0x40, values)
        assert exc.value.code == ILLEGAL_ADDRESS
    with pytest.raises(rtu.RtuError):
        regmap.write_registers(MAP, d, 0x41, [1])
    assert d.moves == [(1, 2, 3)]


def test_whole_s32_takes_both_words_at_the_first_address_only() -> None:
    taken: list[tuple[int, ...]] = []
    m = regmap.s32(0x0700, "target", access="rw", put=lambda d, v: taken.append(v), whole=True)
    d = Drive(target=300)
    regmap.write_registers(m, d, 0x0700, [0, 300])
    assert taken == [(0, 300)]
    for address, values in ((0x0700, [0]), (0x0701, [5])):
        with pytest.raises(rtu.RtuError):
            regmap.write_registers(m, d, address, values)
    assert regmap.read_registers(m, d, 0x0701, 1) == [300]
