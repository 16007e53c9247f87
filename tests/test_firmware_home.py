"""One home per firmware threshold (protocol/firmware.py): read from the source with ast (tokenize for
comments), no import of the modules under test for the static part; no version in code, messages or
prose outside firmware.py and the register table. Then that a new profile or a new threshold is one edit in
one place and flows to the register table, the CLI, the reports and the device gate."""

from __future__ import annotations

import ast
import functools
import io
import re
import tokenize
from pathlib import Path

import pytest

from xarm_emu.protocol import firmware as fw
from xarm_emu.protocol import registers as R
from xarm_emu.protocol import reports

SRC = Path(__file__).resolve().parents[1] / "src" / "xarm_emu"
FIRMWARE = SRC / "protocol" / "firmware.py"
REGISTERS = SRC / "protocol" / "registers.py"
#: A firmware version as data: the whole string, or the last part of register 1's string.
VERSION = re.compile(r"(^|,)[vV]?\d+\.\d+\.\d+$")
#: Names whose value is a version of something else than the box's firmware.
NOT_FIRMWARE = {"__version__"}


#: What a module must hold to be parsed at all: a quoted version, a version comparison's words, a
#: tuple of three integers (parsing all of src/ would cost seconds on a busy machine).
CANDIDATE = re.compile(r"[\"',][vV]?\d+\.\d+\.\d+[\"']|at_least|\.parts\b|\.major\b|\.minor\b|\.revision\b"
                       r"|\(\s*\d+\s*,\s*\d+\s*,\s*\d+\s*\)")


@functools.cache
def texts() -> dict[Path, str]:
    """Every module of src/ (read once, on first use rather than at collection)."""
    return {p: p.read_text() for p in sorted(SRC.rglob("*.py"))}


@functools.cache
def trees() -> dict[Path, ast.Module]:
    """The modules of src/ that may hold a version or a comparison, parsed; firmware.py and
    registers.py always."""
    return {p: ast.parse(t, str(p)) for p, t in texts().items()
            if p in (FIRMWARE, REGISTERS) or CANDIDATE.search(t)}


def _docstrings(tree: ast.Module) -> set[int]:
    """ids of the docstring constants of a module, its classes and functions (prose, not data)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def _version_strings(tree: ast.Module) -> list[tuple[int, str]]:
    """(line, text) of every string constant of ``tree`` that is a version (not prose, not a docstring,
    not the value of a name of :data:`NOT_FIRMWARE`)."""
    skip = _docstrings(tree)
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id in NOT_FIRMWARE
                                                for t in node.targets):
            skip.add(id(node.value))
    return [(n.lineno, n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in skip
            and VERSION.search(n.value)]


def _int_triple(node: ast.AST) -> bool:
    return (isinstance(node, ast.Tuple) and len(node.elts) == 3
            and all(isinstance(e, ast.Constant) and type(e.value) is int for e in node.elts))


def _comparisons(tree: ast.Module) -> list[tuple[int, str]]:
    """(line, what) of every version comparison: ``at_least``, an ordering on ``.parts``/``.major``/
    ``.minor``/``.revision`` or on a tuple of three integer literals."""
    out = []
    for node in ast.walk(tree):
        func = getattr(node, "func", None)
        if isinstance(node, ast.Call) and isinstance(func, ast.Attribute) and func.attr == "at_least":
            out.append((node.lineno, "at_least"))
        if isinstance(node, ast.Compare) and any(isinstance(op, (ast.Lt, ast.LtE, ast.Gt, ast.GtE))
                                                 for op in node.ops):
            for side in (node.left, *node.comparators):
                if isinstance(side, ast.Attribute) and side.attr in ("parts", "major", "minor", "revision"):
                    out.append((node.lineno, f".{side.attr} compared"))
                if _int_triple(side):
                    out.append((node.lineno, "a version tuple compared"))
    return out


def test_no_version_comparison_outside_the_firmware_module():
    found = {str(p.relative_to(SRC)): c for p, t in trees().items()
             if p != FIRMWARE and (c := _comparisons(t))}
    # the register table's own since: registers_for compares each register's since, and nothing else
    assert found.pop("protocol/registers.py", None) == [(_since_line(), "at_least")]
    assert found == {}


def _since_line() -> int:
    src = REGISTERS.read_text().splitlines()
    return next(i for i, line in enumerate(src, 1) if "at_least(reg.since)" in line)


def test_no_version_string_outside_the_two_files():
    found = {str(p.relative_to(SRC)): v for p, t in trees().items()
             if p not in (FIRMWARE, REGISTERS) and (v := _version_strings(t))}
    assert found == {}


def test_no_threshold_string_in_both_files():
    thresholds = {v for _, v in _version_strings(trees()[FIRMWARE])}
    assert set(fw.RELEASES) | set(fw.SUPPORTED_VERSIONS) | {fw.DEFAULT_VERSION} == thresholds
    in_registers = {v for _, v in _version_strings(trees()[REGISTERS])}
    assert in_registers & thresholds == set(), "a threshold of firmware.py written again in registers.py"
    # each threshold once in firmware.py: as a key of RELEASES (a profile version may equal one)
    releases = next(n for n in ast.walk(trees()[FIRMWARE]) if isinstance(n, ast.AnnAssign)
                    and isinstance(n.target, ast.Name) and n.target.id == "RELEASES")
    keys = [k.value for k in ast.walk(releases) if isinstance(k, ast.Constant) and isinstance(k.value, str)
            and VERSION.search(k.value)]
    assert sorted(keys) == sorted(set(keys)) == sorted(fw.RELEASES)


def _properties() -> list[str]:
    cls = next(n for n in ast.walk(trees()[FIRMWARE])
               if isinstance(n, ast.ClassDef) and n.name == "FirmwareProfile")
    return [f.name for f in cls.body if isinstance(f, ast.FunctionDef) and any(
        isinstance(d, ast.Name) and d.id in ("property", "cached_property") for d in f.decorator_list)]


def test_every_profile_property_is_read_by_src():
    """Each property is an attribute read by a module of src/ other than firmware.py (or named as a
    string there, as the register table's later forms name theirs)."""
    props = _properties()
    assert len(props) >= 10
    others = [t for p, t in texts().items() if p != FIRMWARE]
    unread = [name for name in props
              if not any(re.search(rf"\.{name}\b|[\"']{name}[\"']", t) for t in others)]
    assert unread == []


def test_every_behaviour_of_a_release_is_used():
    """A behaviour is a property of that name, a part of PARTS, or the since of registers (first())."""
    firsts = {m for t in texts().values() for m in re.findall(r"\bfirst\(\s*[\"'](\w+)[\"']\s*\)", t)}
    used = set(_properties()) | set(fw.PARTS.values()) | firsts
    behaviours = [b for bs in fw.RELEASES.values() for b in bs]
    assert len(behaviours) == len(set(behaviours))
    assert [b for b in behaviours if b not in used] == []
    assert firsts <= set(behaviours)


# ---- one edit in one place -------------------------------------------------------------------------


@pytest.fixture
def fresh_tables():
    R.registers_for.cache_clear()
    yield
    R.registers_for.cache_clear()


def test_a_new_profile_is_one_entry(monkeypatch, fresh_tables):
    """2.5.0 added to SUPPORTED_VERSIONS alone: the CLI takes it, its register table, modes, report
    frames and device gate follow from the releases it is past."""
    monkeypatch.setattr(fw, "SUPPORTED_VERSIONS", (*fw.SUPPORTED_VERSIONS, "2.5.0"))
    from xarm_emu.cli.serve import checked_arm
    from xarm_emu.controller.applications.modes import extra_modes
    from xarm_emu.controller.emulator import Emulator

    with pytest.raises(fw.VersionError):
        fw.profile_for("2.5.1")
    profile, robot = checked_arm("7t", "2.5.0", None, 700, None, False, True)
    table = R.registers_for(profile)
    assert {254, 200, 83}.issubset(table) and R.inf_unchanged(table) == {21, 23, 83}
    assert set(reports.encoders_for(profile)) == {30000, 30001, 30002, 30003}
    emu = Emulator(robot, firmware="2.5.0", linear_track=700, ft_sensor=True)
    assert emu.controller.version_string().endswith(",v2.5.0") and emu.feedback is not None
    assert extra_modes(emu.controller) == (4, 5, 6, 7)  # velocity control, online planning


def test_a_threshold_is_one_entry(monkeypatch, fresh_tables):
    """Moving the common move forms to 2.0.102 in RELEASES alone moves the register table's layouts
    of 21/23-25/27 with it."""
    releases = {v: tuple(b for b in bs if b != "common_move_layout") for v, bs in fw.RELEASES.items()}
    releases["2.0.102"] += ("common_move_layout",)
    monkeypatch.setattr(fw, "RELEASES", releases)
    assert fw.first("common_move_layout") == "2.0.102"
    old, new = fw.FirmwareProfile.for_version("1.11.100"), fw.FirmwareProfile.for_version("2.0.102")
    assert not old.common_move_layout and new.common_move_layout
    assert R.registers_for(old)[21].request == R.REGISTERS[21].request
    assert R.registers_for(new)[21].reply.size == 3


def test_the_same_refusal_for_every_part():
    old = fw.DEFAULT_PROFILE
    for part, behaviour in fw.PARTS.items():
        with pytest.raises(fw.FirmwareRefusal) as err:
            old.check_parts("xarm gripper", part)
        assert str(err.value) == f"the {part} needs firmware {fw.first(behaviour)} or later, not 1.6.0"
        fw.NEWEST_PROFILE.check_parts(part)
    old.check_parts("xArm6 arm", "robotiq-2f85 gripper", "vacuum gripper")  # every firmware drives them


def _known_version() -> re.Pattern[str]:
    """A release or profile version of protocol/firmware.py inside any text ('v' as register 1 writes
    it; not 'V1.6.0', the manual's own version)."""
    known = sorted({*fw.RELEASES, *fw.SUPPORTED_VERSIONS, fw.DEFAULT_VERSION}, key=len, reverse=True)
    return re.compile(r"(?<![\w.])v?(" + "|".join(map(re.escape, known)) + r")(?![\w.])")


def test_no_known_version_inside_a_message_or_help_text():
    """Beyond whole version strings: no string of src/ outside the two files (a help text, an error
    message, a part of an f-string) names a release or profile version inside its text; it takes the
    name of firmware.py (DEFAULT_VERSION, SERVE_VERSION, first(...)) instead. Docstrings are prose."""
    pattern = _known_version()
    found = {}
    for p, t in texts().items():
        if p in (FIRMWARE, REGISTERS) or not pattern.search(t):
            continue
        tree = trees().get(p) or ast.parse(t, str(p))
        skip = _docstrings(tree)
        hits = [(n.lineno, n.value) for n in ast.walk(tree) if isinstance(n, ast.Constant)
                and isinstance(n.value, str) and id(n) not in skip and pattern.search(n.value)]
        if hits:
            found[str(p.relative_to(SRC))] = hits
    assert found == {}


# ---- prose: comments and docstrings -----------------------------------------------------------------


#: A dotted number, as register 1 writes a version ('v2.4.101') or bare; the end of a sentence is no
#: part of it, nor is it part of a longer number (an IP address).
_NUMBER = re.compile(r"(?<![\w.])([vV]?)(\d+\.\d+(?:\.\d+)?)(?!\.?\d)")
#: What makes a dotted number a firmware version: 'firmware' (also before 'firmware 1.8'), a
#: comparison, 'since', 'from', 'before', 'until'.
_THRESHOLD_WORD = re.compile(r"(?:\bfirmware|[<>]=?|\bsince|\bfrom|\bbefore|\buntil)\s*$", re.IGNORECASE)
#: What a manual's number follows: its section ('manual 2.1.6', 'sections 3.2.1 and 3.2.2') or the
#: manual's own version ('Developer Manual V1.6.0').
_MANUAL = re.compile(r"(?:manual|sections?|\u00a7)\s*(?:[vV]?\d+(?:\.\d+)*\s*(?:,|and|or)\s*)*[vV]?$",
                     re.IGNORECASE)


def versions_in_prose(text: str) -> list[str]:
    """The firmware versions ``text`` names: a dotted number after a word of :data:`_THRESHOLD_WORD`,
    written as register 1 writes it ('v2.4.101'), or a release or profile version of
    protocol/firmware.py; never a manual's section number or the manual's own version."""
    known = {*fw.RELEASES, *fw.SUPPORTED_VERSIONS, fw.DEFAULT_VERSION}
    out = []
    for m in _NUMBER.finditer(text):
        before = text[max(0, m.start() - 60):m.start()]
        three = m[2].count(".") == 2
        named = (m[2] in known or (three and bool(m[1])) or (three and bool(_THRESHOLD_WORD.search(before)))
                 or bool(re.search(r"firmware\s*$", before, re.IGNORECASE)))
        if not named or _MANUAL.search(before + m[1]):
            continue
        out.append(m.group())
    return out


@pytest.mark.parametrize("text", [
    "firmware >= 2.0.102", "Firmware from 1.11.100 takes", "(>= 2.4.101).", "since 1.8.6", "firmware 1.8 and",
    "''6,6,XI1304,AC1303,v2.7.103''", "not on firmware 1.6.0", "firmware 2.9.9.", "From 2.4.101 a +inf",
    "the 850 (2.1.0 and later)"])
def test_a_version_in_prose_is_found(text):
    assert versions_in_prose(text) != []


@pytest.mark.parametrize("text", [
    "manual 2.1.6", "manual section 2.1.3", "sections 3.2.1 and 3.2.2", "(manual 2.1.3,\n    2.1.4)",
    "Developer Manual V1.6.0", "not in manual V1.6.0", "--host 127.0.0.1", "Ericson 5.1.9",
    "servos report 1.0.0", "firmware 2.x", "``vX.Y.Z``", "section 2.1.0"])
def test_a_manual_section_is_no_version(text):
    assert versions_in_prose(text) == []


def _prose(text: str) -> list[tuple[int, str]]:
    """(line, text) of the comments and strings (docstrings among them) of a module."""
    kinds = {tokenize.COMMENT, tokenize.STRING}
    return [(tok.start[0], tok.string) for tok in tokenize.generate_tokens(io.StringIO(text).readline)
            if tok.type in kinds]


def test_no_firmware_version_in_a_comment_or_docstring_outside_the_two_files():
    """A threshold is named by its FirmwareProfile property, its PARTS entry or its behaviour of
    RELEASES, never by the release's version (firmware.py and the register table are its home).
    Only modules whose text holds a candidate are tokenized."""
    found = {}
    for p, t in texts().items():
        if p in (FIRMWARE, REGISTERS) or not versions_in_prose(t):
            continue
        hits = [(line, v) for line, s in _prose(t) for v in versions_in_prose(s)]
        if hits:
            found[str(p.relative_to(SRC))] = hits
    assert found == {}
