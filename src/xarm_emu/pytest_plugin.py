"""The pytest plugin that installing xarm-emu registers (entry point ``pytest11``): an emulator on
free loopback ports per test, the official SDK and the async client pointed at it, a model x
firmware matrix from the command line, and the test's wire trace in the report of a failure.

Fixtures: ``xarm_emulator`` (the running :class:`~xarm_emu.server.app.ServerThread`), ``xarm_sdk``
(a connected ``xarm.wrapper.XArmAPI``), ``xarm_async_client`` (``async with xarm_async_client() as
c``: an :class:`~xarm_emu.client.AsyncClient` on the command port) and ``xarm_settings`` (the
keywords the emulator was started with). ``@pytest.mark.xarm(model=..., firmware=..., speed=...,
**running_emulator keywords)`` sets them per test, class or module; ``--xarm-model`` and
``--xarm-firmware`` (repeatable) run every test that uses the emulator once per combination.
docs/pytest-plugin.md is the user's page.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import inspect
import itertools
import threading
import time
from collections.abc import AsyncIterator, Callable, Iterator
from contextlib import AbstractAsyncContextManager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from .client import AsyncClient
    from .server.app import ServerThread

# The emulator is imported where a fixture or an option needs it: a pytest run that uses none of them
# (any project in an environment where xarm-emu is installed) loads this module only.

#: The axes the command line and a marker's lists turn into a matrix.
AXES = ("model", "firmware")
#: Marker keywords that name a file: relative paths are taken from the test file's directory.
PATH_KEYS = ("scene", "faults", "calibration", "trace")
#: Keywords ``running_emulator`` sets itself (free loopback ports) and a marker may not.
FIXED_KEYS = ("host", "port", "normal_port", "rich_port", "develop_port", "realtime_port", "config_dir")
#: Lines of the wire trace a failing test's report shows unless ``--xarm-trace-lines`` says.
TRACE_LINES = 40


@dataclasses.dataclass(frozen=True)
class Profile:
    """One combination of the matrix; ``None`` where the run does not vary that axis."""

    model: str | None = None
    firmware: str | None = None

    @property
    def id(self) -> str:
        return "-".join(v for v in (self.model, self.firmware) if v is not None)


@dataclasses.dataclass
class _Trace:
    """The wire trace of one test's emulator."""

    server: ServerThread
    path: Path
    running: bool = True  # False once the fixture has stopped the server (the file is complete)

    def settle(self) -> None:
        """Have the server write every line it has collected (while it still runs)."""
        if not self.running:
            return
        srv = self.server.server

        def flush() -> Any:
            if srv.trace is None or srv.disk is None:
                return None
            srv.trace.flush()
            return srv.disk.submit(lambda: None)  # done when the lines before it are written

        with contextlib.suppress(Exception):  # a server that failed: what it wrote is what there is
            done = self.server.call(flush)
            if done is not None:
                done.result(5.0)  # type: ignore[attr-defined]

    def tail(self, n: int) -> tuple[str, int]:
        """The last ``n`` lines and the number of lines in the file."""
        try:
            lines = self.path.read_text(encoding="utf-8", errors="replace").splitlines()
        except OSError as exc:
            return f"(no trace: {exc})", 0
        return "\n".join(lines[-n:] if n > 0 else []), len(lines)


_TRACE = pytest.StashKey[_Trace]()
#: The threads of the disconnected SDKs, waited for at the end of their module.
_SDK_THREADS = pytest.StashKey[list[threading.Thread]]()
#: How long the end of a module waits for them in all (seconds).
SDK_THREADS_WAIT = 5.0


def _model_arg(text: str) -> str:
    from .model.robots import get_model

    try:
        get_model(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _firmware_arg(text: str) -> str:
    from .protocol.firmware import profile_for

    try:
        return str(profile_for(text).version)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("xarm-emu", "xarm-emu: an emulated xArm control box for the tests")
    group.addoption("--xarm-model", action="append", default=[], type=_model_arg, metavar="MODEL",
                    help="run each test that uses the emulator with this arm model "
                         "(5, 6, 7, lite6, 850, 7t); repeat for a matrix")
    group.addoption("--xarm-firmware", action="append", default=[], type=_firmware_arg, metavar="VERSION",
                    help="run each test that uses the emulator with this firmware profile "
                         "(a version xarm-emu serve --firmware takes); repeat for a matrix")
    group.addoption("--xarm-speed", type=float, default=None, metavar="SCALE",
                    help="time scale of every emulator (10: ten times faster than real time; default 1)")
    group.addoption("--xarm-trace-lines", type=int, default=TRACE_LINES, metavar="N",
                    help=f"lines of the wire trace shown for a failing test (default {TRACE_LINES})")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "xarm(model=..., firmware=..., speed=..., **options): the emulated box of this test "
                   "(by default an xArm6 with the manual's firmware at speed 1; options: the keywords of "
                   "xarm_emu.testing.running_emulator, e.g. gripper='bio', linear_track=700, "
                   "scene='scene.toml'); a list for model or firmware is the test's own matrix")


def pytest_report_header(config: pytest.Config) -> str | None:
    models = config.getoption("xarm_model", default=[])
    firmware = config.getoption("xarm_firmware", default=[])
    if not models and not firmware:
        return None
    from . import __version__

    return (f"xarm-emu {__version__}: models {', '.join(models) or 'per test'}; "
            f"firmware {', '.join(firmware) or 'per test'}")


def _marker_options(node: pytest.Item | pytest.Function) -> dict[str, Any]:
    """The ``xarm`` marks of ``node``, the module's first and the test's own last."""
    options: dict[str, Any] = {}
    for mark in reversed(list(node.iter_markers("xarm"))):
        if mark.args:
            raise pytest.UsageError(f"{node.nodeid}: @pytest.mark.xarm takes keywords only, "
                                    f"got {mark.args!r}")
        options.update(mark.kwargs)
    return options


def _axis(options: dict[str, Any], key: str, cli: list[str]) -> list[str] | None:
    """The values a test runs over on one axis: the marker's list, else none when the marker pins
    one value, else the command line's."""
    if key in options:
        value = options[key]
        return [str(v) for v in value] if isinstance(value, (list, tuple)) else None
    return list(dict.fromkeys(cli)) or None


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    if "xarm_profile" not in metafunc.fixturenames:
        return
    options = _marker_options(metafunc.definition)
    axes = [_axis(options, key, metafunc.config.getoption(f"xarm_{key}", default=[])) for key in AXES]
    if all(a is None for a in axes):
        return
    values: list[list[str | None]] = [list(a) if a else [None] for a in axes]
    profiles = [Profile(*combo) for combo in itertools.product(*values)]
    metafunc.parametrize("xarm_profile", profiles, ids=[p.id for p in profiles], indirect=True)


@pytest.fixture
def xarm_profile(request: pytest.FixtureRequest) -> Profile:
    """This test's combination of the matrix (empty when the run has none)."""
    return getattr(request, "param", Profile())


def _known_keys() -> set[str]:
    from .server.app import ServerConfig
    from .testing import running_emulator

    own = {name for name, p in inspect.signature(running_emulator).parameters.items()
           if p.kind is not p.VAR_KEYWORD}
    return (own | {f.name for f in dataclasses.fields(ServerConfig)}) - set(FIXED_KEYS)


@pytest.fixture
def xarm_settings(request: pytest.FixtureRequest, xarm_profile: Profile) -> dict[str, Any]:
    """The keywords this test's emulator starts with (``running_emulator``'s): the marker's over
    the command line's over the defaults (model 6, the manual's firmware ``DEFAULT_VERSION``, speed 1)."""
    from .protocol.firmware import DEFAULT_VERSION

    options = _marker_options(request.node)
    unknown = sorted(set(options) - _known_keys())
    if unknown:
        pytest.fail(f"@pytest.mark.xarm: unknown option(s) {', '.join(unknown)}; known: "
                    f"{', '.join(sorted(_known_keys()))}", pytrace=False)
    config = request.config
    speed = config.getoption("xarm_speed", default=None)
    settings: dict[str, Any] = {"model": "6", "firmware": DEFAULT_VERSION,
                                "speed": 1.0 if speed is None else speed}
    settings.update(options)
    for key in AXES:
        if getattr(xarm_profile, key) is not None:
            settings[key] = getattr(xarm_profile, key)
    base = Path(str(request.node.path)).parent
    for key in PATH_KEYS:
        value = settings.get(key)
        if isinstance(value, (str, Path)):
            settings[key] = base / value  # an absolute path stays as it is
    return settings


@pytest.fixture
def xarm_emulator(request: pytest.FixtureRequest, xarm_settings: dict[str, Any],
                  tmp_path_factory: pytest.TempPathFactory) -> Iterator[ServerThread]:
    """The emulated control box of this test on free loopback ports, its wire trace kept (attached to
    the report when the test fails); stopped at the end of the test."""
    from .testing import running_emulator

    settings = dict(xarm_settings)
    trace = Path(settings.pop("trace", None) or tmp_path_factory.mktemp("xarm-trace") / "trace.jsonl")
    with contextlib.ExitStack() as stack:
        problem: str | None = None
        try:
            st = stack.enter_context(running_emulator(**settings, trace=trace))
        except (ValueError, OSError) as exc:  # a bad model, firmware, scene or fault file
            problem = str(exc)
        if problem is not None:
            pytest.fail(f"xarm-emu could not start the emulator ({_describe(settings)}): {problem}",
                        pytrace=False)
        handle = request.node.stash[_TRACE] = _Trace(st, trace)
        yield st
    handle.running = False


def _describe(settings: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v!r}" for k, v in settings.items())


@pytest.fixture
def xarm_sdk(request: pytest.FixtureRequest, xarm_emulator: ServerThread) -> Iterator[Any]:
    """The official SDK (``xarm.wrapper.XArmAPI``) connected to the emulator, as a user's program
    would connect to 127.0.0.1 (the arm as the box starts: the program enables it); disconnected at
    the end of the test. Needs ``xarm-python-sdk``.

    A disconnected SDK's report thread ends about a second later (and logs it): the plugin waits for
    those threads after the last test of each module, not after each test."""
    wrapper = pytest.importorskip("xarm.wrapper", reason="xarm_sdk needs the official SDK: "
                                                         "pip install xarm-python-sdk")
    from .testing import sdk_pointed_at

    with sdk_pointed_at(xarm_emulator):
        before = set(threading.enumerate())
        arm = wrapper.XArmAPI("127.0.0.1", forbid_uds=True)
        try:
            if not arm.connected:
                pytest.fail("the official SDK did not connect to the emulator", pytrace=False)
            yield arm
        finally:
            arm.disconnect()
            request.config.stash.setdefault(_SDK_THREADS, []).extend(set(threading.enumerate()) - before)


@pytest.fixture
def xarm_async_client(xarm_emulator: ServerThread) -> Callable[[], AbstractAsyncContextManager[AsyncClient]]:
    """``async with xarm_async_client() as client``: the project's async client on the emulator's
    command port, in the running event loop (pytest-asyncio, anyio or ``asyncio.run`` in the test)."""
    from .client import AsyncClient

    port = xarm_emulator.ports["command"]

    @contextlib.asynccontextmanager
    async def connect() -> AsyncIterator[AsyncClient]:
        client = await AsyncClient.connect("127.0.0.1", port)
        try:
            yield client
        finally:
            await client.close()

    return connect


@pytest.hookimpl(trylast=True)
def pytest_runtest_teardown(item: pytest.Item, nextitem: pytest.Item | None) -> None:
    """After a module's last test, wait for the threads of its disconnected SDKs (while pytest still
    captures what they log)."""
    if nextitem is not None and nextitem.path == item.path:
        return
    threads = item.config.stash.get(_SDK_THREADS, [])
    deadline = time.monotonic() + SDK_THREADS_WAIT
    while threads:
        threads.pop().join(timeout=max(0.0, deadline - time.monotonic()))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Iterator[None]:
    """Attach the test's wire trace (its last lines; the file's path as the ``xarm_trace`` property,
    which JUnit XML keeps) to the report of a failed phase."""
    outcome = yield
    report: pytest.TestReport = outcome.get_result()  # type: ignore[attr-defined]
    trace = item.stash.get(_TRACE, None)
    if trace is None or not report.failed:
        return
    trace.settle()
    n = max(0, int(item.config.getoption("xarm_trace_lines", default=TRACE_LINES)))
    text, total = trace.tail(n)
    shown = min(n, total)
    report.sections.append((f"xarm-emu wire trace ({call.when}: last {shown} of {total} lines of "
                            f"{trace.path})", text))
    prop = ("xarm_trace", str(trace.path))
    for props in (report.user_properties, item.user_properties):  # the item's: in later phases' reports
        if prop not in props:
            props.append(prop)

