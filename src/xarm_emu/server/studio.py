"""The xArm Studio HTTP calls the SDK makes (``xarm-emu serve --studio``, port 18333).

The SDK's ``XArmAPI`` reaches UFACTORY Studio on the control box over HTTP for a few functions:

- ``POST /v2/api`` with a JSON body ``{"cmd": name, "args": [params], "kwargs": {}}``, answered
  ``{"code": int, "data": ...}``. The SDK may send it form-encoded, so the body is read as JSON
  whatever its content type. Commands: ``XArm.xarm_initial_point`` (data: 7 joints),
  ``Core.command.xarm_set_initial_point`` (``{"point": [...]}``), ``XArm.xarm_mount_degrees``
  (data: [tilt, rotation] in degrees, from the gravity direction of register 95),
  ``Core.command.xarm_delete_traj`` (``{"filename": name}``), ``Core.command.app_delete_item``
  (``{"parentPath": name, ...}``, a Blockly app).
- ``POST /cmd`` with ``{"cmd": "xarm_list_trajs"}``, answered ``{"res": [code, [{"name", "count"}]]}``
  where ``count`` is the trajectory's length in 10 ms steps (the SDK divides it by 100).

Files: the trajectories are the ones registers 61-65 record and save (``<config dir>/trajectories``,
listed without the ``.traj`` the SDK appends); the initial point is kept in
``<config dir>/studio.json``; Blockly apps are folders or files in ``<config dir>/blockly``. Without a
configuration directory all of it lives in memory. State is read and changed on the server's event
loop; the HTTP server runs on its own thread (the standard library's ``http.server``).

Codes: 0 done; :data:`CODE_BAD_REQUEST` for a command or parameters it cannot take;
:data:`CODE_NOT_FOUND` for a trajectory or app that does not exist (``data`` says why).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import json
import logging
import math
import os
import shutil
import threading
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

from ..controller.applications import trajectory

log = logging.getLogger(__name__)

#: The port Studio listens on (the SDK does not let it be changed).
STUDIO_PORT = 18333
#: ``code`` of a command or parameters that cannot be taken.
CODE_BAD_REQUEST = 1
#: ``code`` of a trajectory or Blockly app that does not exist.
CODE_NOT_FOUND = 2
#: Longest request body read (bytes).
MAX_BODY = 1 << 20
_SUFFIX = ".traj"


class StudioError(Exception):
    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code


class StudioState:
    """The Studio files of one emulator: initial point, Blockly apps, and its trajectories."""

    def __init__(self, emulator: Any) -> None:
        self.emulator = emulator
        cdir = getattr(emulator, "config_dir", None)
        self.config_dir: Path | None = None if cdir is None else Path(cdir)
        self._initial = [0.0] * 7
        if self.config_dir is not None:
            with contextlib.suppress(OSError, ValueError, TypeError, KeyError):
                point = json.loads((self.config_dir / "studio.json").read_text())["initial_point"]
                self._initial = _point(point)

    # -- initial point ---------------------------------------------------------------------
    def initial_point(self) -> list[float]:
        return list(self._initial)

    def set_initial_point(self, point: Any) -> None:
        self._initial = _point(point)
        if self.config_dir is not None:
            self.config_dir.mkdir(parents=True, exist_ok=True)
            tmp = self.config_dir / ".studio.json.tmp"
            tmp.write_text(json.dumps({"initial_point": self._initial}))
            os.replace(tmp, self.config_dir / "studio.json")

    # -- mount ------------------------------------------------------------------------------
    def mount_degrees(self) -> list[float]:
        """[tilt, rotation] (deg) of the gravity direction, as the SDK's set_mount_direction builds
        it: g = Rz(-rotation) Ry(-tilt) (0, 0, -1)."""
        gx, gy, gz = (float(v) for v in self.emulator.controller.settings.gravity_direction)
        norm = math.sqrt(gx * gx + gy * gy + gz * gz) or 1.0
        gx, gy, gz = gx / norm, gy / norm, gz / norm
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, -gz))))
        rotation = 0.0 if math.hypot(gx, gy) < 1e-9 else math.degrees(math.atan2(-gy, gx))
        return [round(tilt, 3), round(rotation, 3)]

    # -- trajectories -----------------------------------------------------------------------
    def _store(self) -> trajectory.TrajectoryStore:
        return trajectory.store_of(self.emulator.controller)

    def _files(self) -> dict[str, bytes | Path]:
        st = self._store()
        if st.directory is None:
            return dict(st.memory)
        if not st.directory.is_dir():
            return {}
        return {p.name: p for p in sorted(st.directory.iterdir())
                if p.is_file() and not p.name.startswith(".")}

    def trajectories(self) -> list[dict[str, Any]]:
        out = []
        for name, src in sorted(self._files().items()):
            try:
                data = json.loads(src.read_bytes() if isinstance(src, Path) else src)
                count = round(len(data["joints"]) * float(data["period"]) * 100)
            except (OSError, ValueError, KeyError, TypeError):
                continue  # not a trajectory this emulator wrote
            out.append({"name": name.removesuffix(_SUFFIX), "count": count})
        return out

    def delete_trajectory(self, name: Any) -> None:
        if not isinstance(name, str) or not name.strip():
            raise StudioError(CODE_BAD_REQUEST, "filename: a trajectory name")
        files = self._files()
        key = next((k for k in (name, name + _SUFFIX) if k in files), None)
        if key is None:
            raise StudioError(CODE_NOT_FOUND, f"no trajectory {name!r}")
        src = files[key]
        if isinstance(src, Path):
            src.unlink()
        else:
            del self._store().memory[key]

    # -- Blockly apps -----------------------------------------------------------------------
    def delete_blockly_app(self, name: Any) -> None:
        if not isinstance(name, str) or not name.strip() or "/" in name or "\\" in name \
                or name.strip(". ") == "":
            raise StudioError(CODE_BAD_REQUEST, "parentPath: a Blockly app name")
        if self.config_dir is None:
            raise StudioError(CODE_NOT_FOUND, f"no Blockly app {name!r}")
        path = self.config_dir / "blockly" / name
        if path.is_dir():
            shutil.rmtree(path)
        elif path.is_file():
            path.unlink()
        else:
            raise StudioError(CODE_NOT_FOUND, f"no Blockly app {name!r}")


def _point(point: Any) -> list[float]:
    if not isinstance(point, list | tuple) or not 1 <= len(point) <= 7:
        raise StudioError(CODE_BAD_REQUEST, "point: a list of up to 7 joint values")
    try:
        values = [float(v) for v in point]
    except (TypeError, ValueError):
        raise StudioError(CODE_BAD_REQUEST, "point: joint values are numbers") from None
    if not all(math.isfinite(v) for v in values):
        raise StudioError(CODE_BAD_REQUEST, "point: joint values are finite")
    return values + [0.0] * (7 - len(values))


def _param(args: Any, key: str) -> Any:
    if not isinstance(args, list) or not args or not isinstance(args[0], dict):
        raise StudioError(CODE_BAD_REQUEST, f"args: [{{{key!r}: ...}}]")
    return args[0].get(key)


def api_call(state: StudioState, cmd: Any, args: Any) -> tuple[int, Any]:
    """The ``(code, data)`` of one ``/v2/api`` command."""
    try:
        if cmd == "XArm.xarm_initial_point":
            return 0, state.initial_point()
        if cmd == "XArm.xarm_mount_degrees":
            return 0, state.mount_degrees()
        if cmd == "Core.command.xarm_set_initial_point":
            state.set_initial_point(_param(args, "point"))
        elif cmd == "Core.command.xarm_delete_traj":
            state.delete_trajectory(_param(args, "filename"))
        elif cmd == "Core.command.app_delete_item":
            state.delete_blockly_app(_param(args, "parentPath"))
        else:
            return CODE_BAD_REQUEST, f"command not supported by the emulator: {cmd!r}"
    except StudioError as exc:
        return exc.code, str(exc)
    except OSError as exc:
        return CODE_BAD_REQUEST, f"{cmd}: {exc.strerror or exc}"
    return 0, None


class StudioServer:
    """The HTTP server, as a server attachment (:meth:`EmulatorServer.attach`)."""

    def __init__(self, emulator: Any, host: str = "127.0.0.1", port: int = STUDIO_PORT,
                 before: Callable[[], object] | None = None,
                 lock: threading.RLock | None = None) -> None:
        self.state = StudioState(emulator)
        self._before = before
        self._lock = lock if lock is not None else threading.RLock()
        self._loop: asyncio.AbstractEventLoop | None = None
        self.httpd = ThreadingHTTPServer((host, port), _handler(self))
        self.httpd.daemon_threads = True
        self.port: int = self.httpd.server_address[1]
        self._thread = threading.Thread(target=self.httpd.serve_forever, name="xarm-emu-studio",
                                        daemon=True)

    def start(self) -> None:
        with contextlib.suppress(RuntimeError):
            self._loop = asyncio.get_running_loop()
        self._thread.start()

    def stop(self) -> None:
        if self._thread.is_alive():
            self.httpd.shutdown()
            self._thread.join(5)
        self.httpd.server_close()

    def on_loop(self, fn: Callable[[], Any]) -> Any:
        """Run ``fn`` where the emulator's state lives (the server's loop), after the due periods."""
        def run() -> Any:
            with self._lock:  # the arm's lock, as a command takes it
                if self._before is not None:
                    self._before()
                return fn()

        loop = self._loop
        if loop is None or loop.is_closed():
            return run()
        fut: concurrent.futures.Future[Any] = concurrent.futures.Future()

        def call() -> None:
            try:
                fut.set_result(run())
            except BaseException as exc:  # noqa: BLE001 - handed to the HTTP thread
                fut.set_exception(exc)

        loop.call_soon_threadsafe(call)
        return fut.result(10)


def _handler(studio: StudioServer) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        server_version = "xarm-emu-studio"

        def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the base signature
            log.debug("studio %s: " + format, self.address_string(), *args)

        def _reply(self, status: int, body: Any) -> None:
            data = json.dumps(body).encode()
            self.send_response(status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def do_GET(self) -> None:  # noqa: N802 - http.server's name
            self._reply(404, {"code": CODE_BAD_REQUEST, "data": "POST /v2/api or /cmd"})

        def do_POST(self) -> None:  # noqa: N802 - http.server's name
            try:
                length = int(self.headers.get("Content-Length") or 0)
            except ValueError:
                length = -1
            if not 0 <= length <= MAX_BODY:
                self._reply(400, {"code": CODE_BAD_REQUEST, "data": "bad Content-Length"})
                return
            try:
                body = json.loads(self.rfile.read(length) or b"{}")
                cmd = body.get("cmd") if isinstance(body, dict) else None
            except (ValueError, UnicodeDecodeError):
                body, cmd = None, None
            path = self.path.split("?", 1)[0].rstrip("/")
            if path == "/v2/api":
                if cmd is None:
                    self._reply(200, {"code": CODE_BAD_REQUEST, "data": "body: JSON with a cmd"})
                    return
                code, data = studio.on_loop(lambda: api_call(studio.state, cmd, body.get("args", [])))
                self._reply(200, {"code": code, "data": data})
            elif path == "/cmd":
                if cmd == "xarm_list_trajs":
                    self._reply(200, {"res": [0, studio.on_loop(studio.state.trajectories)]})
                else:
                    self._reply(200, {"res": [CODE_BAD_REQUEST, f"command not supported: {cmd!r}"]})
            else:
                self._reply(404, {"code": CODE_BAD_REQUEST, "data": f"no endpoint {self.path}"})

    return Handler


def attach_studio(server: Any, host: str = "127.0.0.1", port: int = STUDIO_PORT) -> None:
    """Have ``server`` (an EmulatorServer) serve the Studio HTTP calls on ``host``/``port``, under
    ``ports["studio"]`` once started."""
    server.attach("studio", lambda: StudioServer(server.emulator, host, port, before=server.catch_up,
                                                     lock=server.lock))
