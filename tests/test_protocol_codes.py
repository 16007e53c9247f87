"""Code tables against the manual's chapter 3 (sections 3.1, 3.2.1, 3.2.2, 3.3)."""

from __future__ import annotations

import pytest

from xarm_emu.protocol import codes

# The codes each section of the manual lists.
MANUAL_CONTROLLER = [1, *range(11, 18), 19, *range(21, 38)]  # 3.2.1 (C11-C17 as one row)
MANUAL_WARNINGS = [11, 12, 13, 14]  # 3.2.2
MANUAL_SERVO = [10, 11, 12, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 26, 27, 28, 33, 34, 35, 36, 39, 40,
                49, 52]  # 3.1
MANUAL_GRIPPER = [9, 11, 12, 14, 15, 20, 21, 23, 25, 26, 33, 34, 36]  # 3.3


@pytest.mark.parametrize("table, expected, prefix", [
    (codes.CONTROLLER_ERRORS, MANUAL_CONTROLLER + [10], "C"),
    (codes.WARNINGS, MANUAL_WARNINGS, "W"),
    (codes.SERVO_ERRORS, MANUAL_SERVO, "S"),
    (codes.GRIPPER_ERRORS, MANUAL_GRIPPER, "G"),
])
def test_tables_cover_exactly_the_manual(
    table: dict[int, codes.Code], expected: list[int], prefix: str
) -> None:
    assert sorted(table) == sorted(expected)
    for code, entry in table.items():
        assert entry.code == code and entry.prefix == prefix
        assert entry.name and entry.handling.endswith(".")
        assert entry.label == f"{prefix}{code}"


@pytest.mark.parametrize("code, words", [
    (1, "emergency"), (22, "self-collision"), (23, "joint angle"), (24, "speed"), (31, "collision"),
    (35, "safety boundary"), (36, "36"), (19, "gripper"),
])
def test_controller_error_wording(code: int, words: str) -> None:
    assert words in codes.describe_error(code).lower()


def test_describe_error_format_and_unknown() -> None:
    assert codes.describe_error(35).startswith("C35 Safety boundary limit: ")
    assert codes.describe_error(0) == "no error"
    unknown = codes.describe_error(99)
    assert unknown.startswith("C99 unknown") and "power" in unknown.lower()
    assert codes.describe_warning(12).startswith("W12 Command parameter abnormal")
    assert codes.describe_warning(0) == "no warning"
    assert codes.describe_servo_error(23).startswith("S23 Large motor position deviation")
    assert codes.describe_gripper_error(11).startswith("G11 Gripper current beyond limit")
    assert "unknown" in codes.describe_servo_error(99) and "unknown" in codes.describe_gripper_error(1)


def test_unknown_codes_return_none() -> None:
    for fn in (codes.controller_error, codes.warning, codes.servo_error, codes.gripper_error):
        assert fn(0) is None and fn(255) is None and fn(-1) is None
    assert codes.controller_error(2) is None and codes.warning(15) is None
    assert codes.servo_error(13) is None and codes.gripper_error(10) is None
    assert codes.lookup("X", 1) is None


def test_power_cycle_codes() -> None:
    # 3.2.1: C11-C17 need "power on again"; C1 needs the e-stop released and the arm enabled again.
    for j in range(11, 18):
        assert codes.CONTROLLER_ERRORS[j].restart
        assert f"joint {j - 10}" in codes.CONTROLLER_ERRORS[j].name.lower()
    assert codes.CONTROLLER_ERRORS[1].restart
    assert not codes.CONTROLLER_ERRORS[23].restart and not codes.CONTROLLER_ERRORS[35].restart
    assert codes.SERVO_ERRORS[11].restart and not codes.SERVO_ERRORS[23].restart
    assert not any(w.restart for w in codes.WARNINGS.values())


@pytest.mark.parametrize("label, prefix, code", [
    ("C31", "C", 31), ("c1", "C", 1), (" S23 ", "S", 23), ("G11", "G", 11), ("W11", "W", 11),
])
def test_parse_label(label: str, prefix: str, code: int) -> None:
    entry = codes.parse_label(label)
    assert (entry.prefix, entry.code) == (prefix, code)


@pytest.mark.parametrize("label", ["", "C", "X12", "C1x", "C99", "S13", "G1", "W15", "31", "C-1"])
def test_parse_label_refuses(label: str) -> None:
    with pytest.raises(ValueError):
        codes.parse_label(label)
