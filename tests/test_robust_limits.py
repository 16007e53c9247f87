"""Bounds on clients (``serve --max-connections/--frame-timeout/--backlog``): beyond the per-port
cap new connections are closed at once with one log line per burst while existing clients keep
working; a partial frame (manual 2.1.2) older than the frame timeout closes its connection; with a
1024 open-file limit a flood of 2000 connects neither locks clients out nor burns the CPU; out of
file descriptors, new clients are refused at once and served again once others leave; two emulators
never share a saved configuration."""

from __future__ import annotations

import asyncio
import contextlib
import errno
import logging
import os
import resource
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from helpers import accepts, connect, port_args, recv_exact, serve_ports, wait_for

from xarm_emu.controller.core.config import ConfigLocked, ConfigStore
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import encode_request
from xarm_emu.server.app import ServerConfig, ServerThread
from xarm_emu.server.core import ListenSocket
from xarm_emu.server.fairness import Limits

GET_STATE = 13


def _get_state(s: socket.socket, tid: int = 1) -> int:
    s.sendall(encode_request(tid, GET_STATE))
    head = recv_exact(s, 6)
    recv_exact(s, struct.unpack(">H", head[4:6])[0])
    return int(struct.unpack(">H", head[:2])[0])


def _closed_by_peer(s: socket.socket, timeout: float = 2.0) -> bool:
    s.settimeout(timeout)
    try:
        return s.recv(1) == b""
    except ConnectionResetError:
        return True
    except TimeoutError:
        return False


def _config(**limits: float) -> ServerConfig:
    return ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0,
                        limits=Limits(**limits))  # type: ignore[arg-type]


def test_beyond_the_cap_new_connections_are_refused_with_one_log_line(
        caplog: pytest.LogCaptureFixture) -> None:
    with ServerThread(Emulator(6), _config(max_connections=4)) as st, contextlib.ExitStack() as stack:
        kept = [stack.enter_context(connect(st.ports["command"])) for _ in range(4)]
        for i, s in enumerate(kept):
            assert _get_state(s, i) == i
        with caplog.at_level(logging.INFO, logger="xarm_emu"):
            extra = [stack.enter_context(connect(st.ports["command"])) for _ in range(30)]
            assert all(_closed_by_peer(s) for s in extra)
            reports = [stack.enter_context(connect(st.ports["develop"])) for _ in range(4)]
            late = stack.enter_context(connect(st.ports["develop"]))
            assert _closed_by_peer(late)
            assert not any(_closed_by_peer(s, 0.05) for s in reports)
        for i, s in enumerate(kept):  # the existing clients keep working
            assert _get_state(s, 100 + i) == 100 + i
        refusals = [r for r in caplog.records if "refusing new ones" in r.getMessage()]
        assert len(refusals) == 2  # one per port and burst, not one per attempt
        assert "command port" in refusals[0].getMessage()
        assert "develop report port" in refusals[1].getMessage()


def test_a_partial_frame_older_than_the_timeout_closes_its_connection() -> None:
    with ServerThread(Emulator(6), _config(frame_timeout=0.3)) as st:
        with connect(st.ports["command"]) as partial, connect(st.ports["command"]) as silent, \
                connect(st.ports["command"]) as good:
            assert _get_state(good) == 1
            partial.sendall(encode_request(2, GET_STATE)[:4])
            t0 = time.monotonic()
            assert _closed_by_peer(partial)
            assert 0.25 < time.monotonic() - t0 < 1.5
            assert _closed_by_peer(silent)  # connected and never completed a frame
            time.sleep(0.4)
            assert _get_state(good, 3) == 3  # whole frames, then idle: kept


def test_a_slow_but_whole_frame_within_the_timeout_is_answered() -> None:
    with ServerThread(Emulator(6), _config(frame_timeout=0.5)) as st, connect(st.ports["command"]) as s:
        frame = encode_request(7, GET_STATE)
        s.sendall(frame[:3])
        time.sleep(0.2)
        s.sendall(frame[3:])
        head = recv_exact(s, 6)
        assert struct.unpack(">H", head[:2])[0] == 7


def _cpu_seconds(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _limit_files() -> None:
    """The common limits: soft 1024, hard 8192 (``serve`` raises the soft one to the hard one)."""
    hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
    resource.setrlimit(resource.RLIMIT_NOFILE, (1024, 8192 if hard == resource.RLIM_INFINITY
                                                else min(hard, 8192)))


def _serve_under_common_limits(tmp_path: Path) -> tuple[subprocess.Popen[str], list[int], int, Path]:
    """``serve`` in a child process under soft 1024 / hard 8192: (process, ports, last port, log)."""
    ports, last = serve_ports()
    log_path = tmp_path / "serve.log"
    with open(log_path, "w") as log_file:
        proc = subprocess.Popen([sys.executable, "-m", "xarm_emu.cli", "serve", *port_args(*ports),
                                 "--config-dir", str(tmp_path), "--log-level", "INFO"],
                                stdout=log_file, stderr=subprocess.STDOUT, preexec_fn=_limit_files,
                                env={**os.environ, "COLUMNS": "500"}, text=True)
    return proc, ports, last, log_path


@pytest.fixture
def file_limit_restored() -> Iterator[None]:
    """This process's open-file limits as they were before the test, whatever it raised."""
    limits = resource.getrlimit(resource.RLIMIT_NOFILE)
    yield
    resource.setrlimit(resource.RLIMIT_NOFILE, limits)


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="needs /proc (Linux)")
@pytest.mark.usefixtures("file_limit_restored")
def test_2000_connects_under_a_1024_file_limit_lock_nobody_out(tmp_path: Path) -> None:
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard < 2300:
        pytest.skip("this test opens 2000 sockets")
    if soft != resource.RLIM_INFINITY and soft < 2300:
        resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, 4096) if hard != resource.RLIM_INFINITY
                                                    else 4096, hard))
    proc, ports, last, log_path = _serve_under_common_limits(tmp_path)
    try:
        assert wait_for(lambda: accepts(last), 15.0)
        with contextlib.ExitStack() as stack:
            first = stack.enter_context(connect(ports[0]))
            assert _get_state(first) == 1
            flood = []
            for _ in range(2000):  # idle connections: connect and send nothing
                s = socket.socket()
                s.setblocking(False)
                stack.callback(s.close)
                with contextlib.suppress(BlockingIOError):
                    s.connect(("127.0.0.1", ports[0]))
                flood.append(s)
            time.sleep(1.0)
            cpu0 = _cpu_seconds(proc.pid)
            time.sleep(2.0)  # idle-flooded: nothing more happens
            cpu = (_cpu_seconds(proc.pid) - cpu0) / 2.0
            assert _get_state(first, 2) == 2  # the existing client keeps working
            with connect(ports[0]) as late:  # beyond the cap: refused at once, cleanly
                assert _closed_by_peer(late)
            with connect(ports[3]) as report:  # the other ports still take clients
                assert len(recv_exact(report, 4)) == 4
        for s in flood:
            s.close()
        time.sleep(0.5)
        with connect(ports[0]) as again:  # once the flood has gone, new clients are served
            assert _get_state(again, 3) == 3
    finally:
        proc.terminate()
        proc.wait(5)
    log = log_path.read_text()
    assert cpu < 0.20, log  # no accept loop spinning on EMFILE
    assert len(log.splitlines()) < 20, log
    assert "Traceback" not in log


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="needs /proc (Linux)")
@pytest.mark.usefixtures("file_limit_restored")
def test_1000_idle_connections_under_soft_1024_hard_8192_are_all_answered(tmp_path: Path) -> None:
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard < 8192:
        pytest.skip("needs a hard open-file limit of 8192")
    resource.setrlimit(resource.RLIMIT_NOFILE, (4096, hard))  # this test's own 1000 sockets
    proc, ports, last, log_path = _serve_under_common_limits(tmp_path)
    try:
        assert wait_for(lambda: accepts(last), 15.0)
        with contextlib.ExitStack() as stack:
            conns = [stack.enter_context(socket.create_connection(("127.0.0.1", ports[0]), timeout=5))
                     for _ in range(1000)]
            time.sleep(0.5)  # idle
            for i, s in enumerate(conns):
                s.sendall(encode_request(i, GET_STATE))
            answered = sum(_get_reply_tid(s) == i for i, s in enumerate(conns))
    finally:
        proc.terminate()
        proc.wait(5)
    log = log_path.read_text()
    assert answered == 1000, log
    assert "open-file limit raised from 1024 to 8192: 1000 connections per port" in log


def _get_reply_tid(s: socket.socket) -> int:
    try:
        head = recv_exact(s, 6)
        recv_exact(s, struct.unpack(">H", head[4:6])[0])
    except (OSError, AssertionError, EOFError):
        return -1
    return int(struct.unpack(">H", head[:2])[0])


def test_two_boxes_with_the_same_serial_number_never_share_a_saved_configuration(tmp_path: Path) -> None:
    first = ConfigStore(tmp_path, "XI1300000001")
    first.lock()
    second = ConfigStore(tmp_path, "XI1300000001")
    with pytest.raises(ConfigLocked, match="in use by a running emulator"):
        second.lock()
    other = ConfigStore(tmp_path, "XI1300000002")
    other.lock()  # another serial number: its own file, its own lock
    first.unlock()
    second.lock()  # released: the next box may have it
    second.unlock()
    other.unlock()


def test_a_second_serve_of_the_same_model_and_directory_refuses_to_start(tmp_path: Path) -> None:
    (a, a_last), (b, _) = serve_ports(), serve_ports()
    cmd = [sys.executable, "-m", "xarm_emu.cli", "serve", "--config-dir", str(tmp_path)]
    first = subprocess.Popen([*cmd, *port_args(*a)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        assert wait_for(lambda: accepts(a_last), 15.0)
        second = subprocess.run([*cmd, *port_args(*b)], capture_output=True, text=True, timeout=30,
                                env={**os.environ, "COLUMNS": "500"})
        assert second.returncode == 2
        assert "in use by a running emulator" in second.stderr + second.stdout
        assert not accepts(b[0])
    finally:
        first.terminate()
        first.wait(5)


def _limit_files_64() -> None:
    resource.setrlimit(resource.RLIMIT_NOFILE, (64, 64))  # nothing to raise


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="needs /proc (Linux)")
def test_out_of_file_descriptors_new_clients_are_refused_at_once_and_served_once_others_leave(
        tmp_path: Path) -> None:
    """A cap above what the open-file limit allows: the process runs out of descriptors. A client
    already connected keeps working, new ones are closed at once (none left waiting in the accept
    queue), nothing spins, one log line and no traceback; once clients leave, a new one is served."""
    ports, last = serve_ports()
    log_path = tmp_path / "serve.log"
    with open(log_path, "w") as log_file:
        proc = subprocess.Popen([sys.executable, "-m", "xarm_emu.cli", "serve", *port_args(*ports),
                                 "--config-dir", str(tmp_path), "--log-level", "INFO",
                                 "--max-connections", "1000"],
                                stdout=log_file, stderr=subprocess.STDOUT, preexec_fn=_limit_files_64,
                                env={**os.environ, "COLUMNS": "500"})
    try:
        assert wait_for(lambda: accepts(last), 15.0)
        with contextlib.ExitStack() as stack:
            first = stack.enter_context(connect(ports[0]))
            assert _get_state(first, 1) == 1
            flood = []
            for _ in range(200):  # far more than the 64 descriptors the server may open
                s = socket.socket()
                s.setblocking(False)
                stack.callback(s.close)
                with contextlib.suppress(BlockingIOError):
                    s.connect(("127.0.0.1", ports[0]))
                flood.append(s)
            assert wait_for(lambda: _open_fds(proc.pid) >= 63, 10.0), _open_fds(proc.pid)
            # a connection the server has not yet seen close (the readiness probe's) still holds
            # its descriptor when the flood fills the rest: once it is gone, one more client is
            # served as usual, so the test fills what became free before it tries the late one
            for _ in range(8):
                held = _settled_fds(proc.pid)
                if held >= 64:
                    break
                stack.enter_context(connect(ports[0]))
            assert _settled_fds(proc.pid) == 64, _open_fds(proc.pid)
            late = stack.enter_context(connect(ports[0]))
            assert _closed_by_peer(late, 5.0)  # refused at once, not left waiting for a descriptor
            assert _get_state(first, 2) == 2  # the existing client keeps working
            time.sleep(0.5)
            cpu0 = _cpu_seconds(proc.pid)
            time.sleep(2.0)
            cpu = (_cpu_seconds(proc.pid) - cpu0) / 2.0
        # the flood has gone (every socket closed above): once the server has seen its clients
        # leave, the next client is served
        assert wait_for(lambda: 0 < _open_fds(proc.pid) < 40, 10.0), _open_fds(proc.pid)
        with connect(ports[0], timeout=10.0) as again:
            assert _get_state(again, 5) == 5
        assert proc.poll() is None
    except (AssertionError, OSError) as exc:  # what the server said, with the failure
        raise AssertionError(f"{exc!r}; fds {_open_fds(proc.pid)}; server log:\n{log_path.read_text()}") \
            from exc
    finally:
        proc.terminate()
        proc.wait(5)
    log = log_path.read_text()
    assert cpu < 0.20, log  # no accept loop spinning on EMFILE
    fds = [line for line in log.splitlines() if "cannot accept connections" in line]
    assert 1 <= len(fds) <= 3, log
    assert "Traceback" not in log


def _settled_fds(pid: int, quiet: float = 0.3, timeout: float = 10.0) -> int:
    """The process's open descriptors once their count has not changed for ``quiet`` seconds."""
    count, since, end = _open_fds(pid), time.monotonic(), time.monotonic() + timeout
    while time.monotonic() < end:
        time.sleep(0.02)
        now = _open_fds(pid)
        if now != count:
            count, since = now, time.monotonic()
        elif time.monotonic() - since >= quiet:
            break
    return count


def _open_fds(pid: int) -> int:
    with contextlib.suppress(OSError):
        return len(os.listdir(f"/proc/{pid}/fd"))
    return -1


class _NoDescriptors(ListenSocket):
    """A listening socket whose accepts fail with EMFILE until ``until`` (monotonic seconds) and that
    never gets its spare descriptor: the path where asyncio pauses accepting and tries again."""

    until = 0.0
    calls = 0

    def take_spare(self) -> bool:
        return False

    def _accept(self) -> tuple[int, object]:
        self.calls += 1
        if time.monotonic() < self.until:
            raise OSError(errno.EMFILE, "Too many open files")
        return super()._accept()  # type: ignore[misc, no-any-return]


def test_without_a_spare_descriptor_accepting_pauses_without_spinning_and_resumes() -> None:
    async def run() -> tuple[bytes, int, float]:
        sock = _NoDescriptors(socket.AF_INET, socket.SOCK_STREAM)
        sock.bind(("127.0.0.1", 0))
        sock.setblocking(False)
        sock.until = time.monotonic() + 0.3
        loop = asyncio.get_running_loop()
        errors: list[BaseException] = []
        loop.set_exception_handler(lambda _lp, ctx: errors.append(ctx["exception"]))

        async def echo(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            writer.write(await reader.readexactly(4))
            await writer.drain()
            writer.close()

        server = await asyncio.start_server(echo, sock=sock, backlog=100)
        async with server:
            t0 = time.monotonic()
            reader, writer = await asyncio.open_connection("127.0.0.1", sock.getsockname()[1])
            writer.write(b"ping")
            answer = await asyncio.wait_for(reader.readexactly(4), 10.0)
            writer.close()
            assert len(errors) == 1 and isinstance(errors[0], OSError)  # one report, one retry
            return answer, sock.calls, time.monotonic() - t0

    answer, calls, took = asyncio.run(run())
    assert answer == b"ping"  # served once descriptors are back: asyncio's retry came
    assert calls <= 3  # the failed accept, then the retry's: no accept per backlog slot
    assert took >= 0.3
