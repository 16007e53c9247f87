"""Helpers for testing programs that use the official SDK against the emulator, in one process and
without root: the emulator on free loopback ports, and the SDK pointed at them.

The SDK has no port argument (port 502 and the report ports are constants of its configuration),
and it picks its report structure by the standard report port numbers. :func:`sdk_pointed_at`
patches both for the duration of a ``with`` block::

    from xarm.wrapper import XArmAPI
    from xarm_emu.testing import running_emulator, sdk_pointed_at

    with running_emulator(model=6, speed=5.0) as st, sdk_pointed_at(st):
        arm = XArmAPI("127.0.0.1")
        ...
        arm.disconnect()

``st.emulator`` is the in-process :class:`~xarm_emu.controller.emulator.Emulator` (fault injection,
inputs); run calls on it through ``st.call(...)`` while the server runs.
"""

from __future__ import annotations

import contextlib
import socket
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from .controller import contact
from .controller.emulator import Emulator
from .protocol.firmware import DEFAULT_VERSION
from .server.app import ServerConfig, ServerThread
from .viewer.app import attach_viewer

#: SDK configuration attribute of each report port, and the standard port its parser expects.
_SDK_REPORT_PORTS = {"normal": ("TCP_REPORT_NORM_PORT", 30001), "rich": ("TCP_REPORT_RICH_PORT", 30002),
                     "develop": ("TCP_REPORT_REAL_PORT", 30003)}


@contextlib.contextmanager
def running_emulator(model: int | str = 6, *, config_dir: Path | None = None, vacuum: bool = False,
                     firmware: str = DEFAULT_VERSION, linear_track: int | None = None,
                     ft_sensor: bool = False, ft_noise: bool = True, scene: Any = None, gripper: str = "xarm",
                     **config: Any) -> Iterator[ServerThread]:
    """An emulator server on free loopback ports (``ServerConfig`` fields as keywords, e.g.
    ``speed=5.0``, ``admin=True``), stopped at the end of the block. Saved configuration goes to a
    temporary directory unless ``config_dir`` is given; ``vacuum`` attaches the xArm Vacuum Gripper
    (as ``serve --vacuum``); ``gripper`` the gripper on the tool RS-485 (as ``serve --gripper``:
    xarm, robotiq-2f85, robotiq-2f140, bio, bio-g1 or inspire-rh56); ``firmware`` is the version the
    box claims (as ``serve --firmware``);
    ``linear_track`` attaches a linear track that many mm long (as ``serve --linear-track``; it needs
    ``firmware`` 1.8.0 or later, e.g. ``"2.7.103"``).
    ``ft_sensor`` mounts the six-axis F/T sensor (as ``serve --ft-sensor``; ``ft_noise=False`` for
    deterministic readings) and ``scene`` sets a contact scene (a TOML file path, a
    :class:`~xarm_emu.controller.contact.Scene` or its tables, as ``serve --scene``).
    A ``faults`` schedule is checked and scheduled, ``view=True`` attaches
    the 3D view, as ``xarm-emu serve`` does."""
    with contextlib.ExitStack() as stack:
        if config_dir is None:
            config_dir = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="xarm-emu-")))
        cfg = ServerConfig(**{"host": "127.0.0.1", "port": 0, "normal_port": 0, "rich_port": 0,
                              "develop_port": 0, **config})
        if isinstance(scene, (str, Path)):
            scene = contact.load_scene(scene)
        elif isinstance(scene, dict):
            scene = contact.parse_scene(scene)
        emu = Emulator(model, config_dir=config_dir, vacuum=vacuum, firmware=firmware,
                       linear_track=linear_track, ft_sensor=ft_sensor,
                       ft_noise=ft_noise, scene=scene, gripper=gripper)
        st = ServerThread(emu, cfg,
                          compose=(attach_viewer,)).start()
        try:
            yield st
        finally:
            st.stop()


@contextlib.contextmanager
def sdk_pointed_at(server: ServerThread) -> Iterator[None]:
    """Point the official SDK (``xarm-python-sdk``) at ``server``'s ports for the block; restores the
    SDK's configuration and the process-wide default socket timeout it sets."""
    from xarm.core.config.x_config import XCONF
    from xarm.x3.report import ReportDataStructure

    conf = XCONF.SocketConf
    ports = server.ports
    saved = {"TCP_CONTROL_PORT": conf.TCP_CONTROL_PORT}
    saved.update({attr: getattr(conf, attr) for attr, _ in _SDK_REPORT_PORTS.values()})
    original = ReportDataStructure.__dict__["create"]
    mapping = {ports[kind]: standard for kind, (_, standard) in _SDK_REPORT_PORTS.items()}
    create = original.__func__

    def create_for(cls: type, sock_port: int, **kw: Any) -> Any:
        return create(cls, mapping.get(sock_port, sock_port), **kw)

    previous_timeout = socket.getdefaulttimeout()
    conf.TCP_CONTROL_PORT = ports["command"]
    for kind, (attr, _) in _SDK_REPORT_PORTS.items():
        setattr(conf, attr, ports[kind])
    ReportDataStructure.create = classmethod(create_for)  # type: ignore[method-assign, assignment]
    try:
        yield
    finally:
        ReportDataStructure.create = original  # type: ignore[method-assign]
        for attr, value in saved.items():
            setattr(conf, attr, value)
        socket.setdefaulttimeout(previous_timeout)
