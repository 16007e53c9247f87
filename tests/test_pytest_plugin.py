"""The pytest plugin (``xarm_emu.pytest_plugin``, docs/pytest-plugin.md) run by pytest itself on small
test files (pytester, in this process): the matrix from ``--xarm-model``/``--xarm-firmware``, the
marker's settings reaching the emulator, the wire trace in a failure's report, and clear answers to
bad options. The project's suite does not load plugins automatically, so each run names it."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

pytest_plugins = ["pytester"]

PLUGIN = ("-p", "xarm_emu.pytest_plugin", "-p", "no:cacheprovider")

#: What the box answers on the wire (register 1 through the async client) in each test.
VERSION_TESTS = """
import asyncio
import pytest

def version(connect):
    async def ask():
        async with connect() as client:
            return await client.get_version()
    return asyncio.run(ask())

def test_the_box_claims_the_profile(xarm_async_client, xarm_settings, xarm_profile):
    text = version(xarm_async_client)
    print("VERSION", xarm_profile.id or "-", text)
    assert text.endswith("v" + xarm_settings["firmware"])

@pytest.mark.xarm(firmware="2.7.103")
def test_pinned_to_one_firmware(xarm_async_client):
    assert version(xarm_async_client).endswith("v2.7.103")

def test_without_the_emulator():
    pass
"""


def outcomes(pytester: pytest.Pytester, *args: str) -> dict[str, tuple[str, str]]:
    """Run pytest on the files made; each test's id (after ``::``) and its call's outcome and output."""
    reprec = pytester.inline_run(*PLUGIN, *args)
    return {r.nodeid.split("::", 1)[1]: (r.outcome, r.capstdout)
            for r in reprec.getreports("pytest_runtest_logreport") if r.when == "call"}


def test_each_test_runs_once_per_firmware_given(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_versions=VERSION_TESTS)
    got = outcomes(pytester, "--xarm-firmware", "1.6.0", "--xarm-firmware", "2.7.103")
    claims = "test_the_box_claims_the_profile"
    assert {k: v[0] for k, v in got.items()} == {
        f"{claims}[1.6.0]": "passed", f"{claims}[2.7.103]": "passed",
        "test_pinned_to_one_firmware": "passed", "test_without_the_emulator": "passed"}
    assert got[f"{claims}[1.6.0]"][1] == "VERSION 1.6.0 6,6,XI1300,AC1300,v1.6.0\n"
    assert got[f"{claims}[2.7.103]"][1] == "VERSION 2.7.103 6,6,XI1300,AC1300,v2.7.103\n"
    result = pytester.runpytest_inprocess(*PLUGIN, "--xarm-firmware", "1.6.0", "--xarm-firmware", "2.7.103")
    result.assert_outcomes(passed=4)
    result.stdout.fnmatch_lines(["xarm-emu *: models per test; firmware 1.6.0, 2.7.103"])


def test_models_and_firmware_make_a_cross_product(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_versions=VERSION_TESTS)
    got = outcomes(pytester, "-k", "claims", "--xarm-model", "5", "--xarm-model", "lite6",
                   "--xarm-firmware", "1.6.0", "--xarm-firmware", "2.7.103")
    assert sorted(got) == [f"test_the_box_claims_the_profile[{m}-{f}]"
                           for m in ("5", "lite6") for f in ("1.6.0", "2.7.103")]
    assert all(outcome == "passed" for outcome, _ in got.values())
    for name, (_, out) in got.items():  # register 1 starts with the axis count: 5, else 6 (Lite 6)
        assert out.startswith(f"VERSION {name[name.index('[') + 1:-1]} {'5,5' if '[5-' in name else '6,'}")


def test_without_options_nothing_is_parametrized(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_versions=VERSION_TESTS)
    got = outcomes(pytester)
    assert got["test_the_box_claims_the_profile"] == ("passed", "VERSION - 6,6,XI1300,AC1300,v1.6.0\n")
    assert len(got) == 3


def test_the_marker_sets_the_box_and_its_devices(pytester: pytest.Pytester) -> None:
    pytester.makefile(".toml", table='[[plane]]\nname = "table"\npoint = [0, 0, 50]\nnormal = [0, 0, 1]\n'
                      'stiffness = 10.0\n')
    pytester.makepyfile(test_marker="""
import pytest
from xarm_emu.controller.scene.contact import scene_of

pytestmark = pytest.mark.xarm(model="lite6", speed=4.0)

@pytest.mark.xarm(firmware="2.7.103", gripper="bio", linear_track=1000, scene="table.toml")
def test_devices(xarm_emulator):
    emu = xarm_emulator.emulator
    assert emu.model.name == "Lite 6" or emu.model.axis == 6
    assert str(emu.firmware) == "2.7.103"
    assert xarm_emulator.server.config.speed == 4.0
    assert emu.gripper_kind == "bio"
    assert emu.linear_track is not None
    assert [s.name for s in scene_of(emu.controller).shapes] == ["table"]

@pytest.mark.xarm(firmware=["2.0.102", "2.4.101"])
def test_own_matrix(xarm_emulator, xarm_profile):
    assert str(xarm_emulator.emulator.firmware) == xarm_profile.firmware

@pytest.mark.xarm(grip="bio")
def test_unknown_option(xarm_emulator):
    pass

@pytest.mark.xarm(firmware="1.6.0", linear_track=700)
def test_impossible_box(xarm_emulator):
    pass
""")
    result = pytester.runpytest_inprocess(*PLUGIN, "-rA", "--xarm-speed", "9", "--xarm-firmware", "2.7.1")
    result.assert_outcomes(passed=3, errors=2)
    result.stdout.fnmatch_lines_random([
        "PASSED *::test_devices", "PASSED *::test_own_matrix?2.0.102?", "PASSED *::test_own_matrix?2.4.101?",
        "*@pytest.mark.xarm: unknown option(s) grip; known: *",
        "*xarm-emu could not start the emulator (*): the linear track needs firmware 1.8.0 or later*",
    ])


def test_a_failure_shows_the_wire_trace(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_fails="""
def test_reads_then_fails(xarm_sdk):
    code, pose = xarm_sdk.get_position()
    assert code == 0
    assert pose[0] == 1.0, "the arm is not where the program expected"

def test_passes(xarm_emulator):
    assert xarm_emulator.ports["command"] > 0
""")
    junit = pytester.path / "junit.xml"
    result = pytester.runpytest_inprocess(*PLUGIN, "--xarm-firmware", "2.7.103", "--xarm-trace-lines", "5",
                                          f"--junitxml={junit}")
    result.assert_outcomes(passed=1, failed=1)
    out = result.stdout.str()
    assert out.count("xarm-emu wire trace") == 1, out
    result.stdout.fnmatch_lines([
        "*the arm is not where the program expected*",
        "*xarm-emu wire trace (call: last * lines of *trace.jsonl)*",
        '{"event": "connect", *',
        '*"register": 1, "name": "GET_VERSION"*',
        '*"register": 41, "name": "GET_TCP_POSE", *"state": *',
    ])
    failed = [c for c in ET.parse(junit).getroot().iter("testcase") if c.find("failure") is not None]
    assert len(failed) == 1
    props = {p.get("name"): p.get("value") for p in failed[0].iter("property")}
    assert props["xarm_trace"].endswith("trace.jsonl")


def test_bad_command_line_values_are_usage_errors(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_versions=VERSION_TESTS)
    result = pytester.runpytest_inprocess(*PLUGIN, "--xarm-firmware", "3.0.0")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["*--xarm-firmware: firmware 3.0.0 not supported; choose one of 1.6.0, *"])
    result = pytester.runpytest_inprocess(*PLUGIN, "--xarm-model", "9")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["*--xarm-model: unknown robot model '9'; known: 5, 6, 7, lite6, 850, 7t*"])


def test_a_settings_fixture_of_ones_own_replaces_the_plugins(pytester: pytest.Pytester) -> None:
    pytester.makeconftest("""
import pytest

@pytest.fixture(params=[{"model": "7", "firmware": "2.4.101"}, {"model": "5", "firmware": "1.6.0"}],
                ids=["xarm7", "xarm5"])
def xarm_settings(request):
    return request.param
""")
    pytester.makepyfile(test_versions=VERSION_TESTS)
    got = outcomes(pytester, "-k", "claims")
    claims = "test_the_box_claims_the_profile"
    assert got == {f"{claims}[xarm7]": ("passed", "VERSION - 7,7,XS1300,AC1300,v2.4.101\n"),
                   f"{claims}[xarm5]": ("passed", "VERSION - 5,5,XF1300,AC1300,v1.6.0\n")}
