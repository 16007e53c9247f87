"""The 3D view in the browser (viser): the arm as the self-collision check sees it, its TCP frame,
the safety boundary when it is on, and in virtual robot mode (register 79) the physical arm as a
ghost beside the commanded one.

Started by ``xarm-emu serve --view``, which attaches it beside the server (:func:`attach_viewer`);
it binds the server's ``--host`` unless ``--view-host`` says otherwise. Beside the scene, the
pendant (:mod:`.pendant`) shows the status and carries out the actions.
The attached tools are drawn too: the xArm gripper's fingers at their opening, the vacuum cup, and
the linear track's rail sliding under the carriage (scene.track_parts).
Updates run as a task of the server's event loop at :data:`RATE` Hz and only read the emulator.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from typing import Any

import numpy as np

from ..controller.devices import ft_sensor
from ..controller.emulator import Emulator
from ..controller.scene import contact
from ..server.core import EmulatorServer
from . import scene
from .pendant import Pendant, describe_state

RATE = 30.0  # Hz
PANEL_EVERY = 3  # the status panel and the plot refresh every this many scene updates
ARM_COLOR = (200, 205, 215)
ERROR_COLOR = (230, 40, 40)  # the arm while a control box error stands (register 15 non-zero)
GHOST_COLOR = (120, 170, 255)
TOOL_COLOR = (255, 170, 60)
TRACK_COLOR = (90, 95, 105)
CONTACT_COLOR = (120, 160, 220)  # the contact scene's planes and boxes
OBJECT_COLOR = (208, 64, 32)  # the scene's loose objects (controller/physics/) without a colour of their own
HEMISPHERE_LIGHT = 2.5  # the fill light that stands in for viser's environment map


class _Redrawing:
    """A view redrawn :data:`RATE` times a second by a task of the running event loop (the server's),
    in which its pendants carry out their actions too."""

    _task: asyncio.Task[None] | None = None

    def pendants(self) -> list[Pendant]:
        raise NotImplementedError

    def update(self) -> None:
        raise NotImplementedError

    def start(self) -> None:
        """Start updating from the running event loop (the server's)."""
        loop = asyncio.get_running_loop()
        for pendant in self.pendants():
            pendant.loop = loop
        self._task = loop.create_task(self._run())

    async def _run(self) -> None:
        while True:
            self.update()
            await asyncio.sleep(1.0 / RATE)

    def _cancel(self) -> None:
        if self._task is not None:
            self._task.cancel()
            self._task = None


class Viewer(_Redrawing):
    """A viser server showing one emulator."""

    def __init__(self, emulator: Emulator, host: str = "127.0.0.1", port: int = 8080,
                 server: EmulatorServer | None = None, *, viser_server: Any = None, root: str = "") -> None:
        """Serve on ``host``/``port``, or draw under the scene path ``root`` of a ``viser_server`` that
        someone else owns (the fleet view); with ``server`` the pendant's panel is added."""
        self.emulator = emulator
        self._root = root
        self._owns = viser_server is None
        if viser_server is None:
            viser_server = _new_viser(host, port)
        self.server = viser_server
        self.host = host
        self.port = int(self.server.get_port())
        self._handles: dict[str, Any] = {}
        self._sizes: dict[str, tuple[float, float, tuple[float, float, float]]] = {}
        self._colors: dict[str, tuple[int, int, int]] = {}
        self._meshes: dict[tuple[str, float, float], tuple[np.ndarray, np.ndarray]] = {}
        self._task: asyncio.Task[None] | None = None
        self.updates = 0
        sc = self.server.scene
        if self._owns:
            self.server.initial_camera.position = (1.1, -0.9, 0.8)
            self.server.initial_camera.look_at = (0.15, 0.0, 0.25)
            sc.add_grid("/ground", width=2.0, height=2.0, cell_size=0.1)
        self._tcp = sc.add_frame(f"{root}/tcp", axes_length=0.08, axes_radius=0.004)
        self._boundary = sc.add_box(f"{root}/boundary", color=(255, 80, 80), dimensions=(1, 1, 1),
                                    wireframe=True, visible=False)
        #: The status panel and actions; only with the server, whose loop carries out the actions.
        self.pendant = Pendant(self.server.gui, server) if server is not None else None

    def pendants(self) -> list[Pendant]:
        return [] if self.pendant is None else [self.pendant]

    def update(self) -> None:
        """Redraw from the emulator's current state."""
        ctl = self.emulator.controller
        physical = ctl.physical_joints
        arm_color = ERROR_COLOR if ctl.error_code else ARM_COLOR  # an error stands out in the scene too
        self._draw("arm", scene.arm_parts(ctl.model, ctl.q, ctl.collision_tool), arm_color, 1.0, True)
        ghost = ctl.simulation_robot
        self._draw("physical", scene.arm_parts(ctl.model, physical, ctl.collision_tool) if ghost else [],
                   GHOST_COLOR, 0.35, ghost)
        pos, wxyz = scene.tcp_frame(ctl.model, ctl.q, ctl.settings.tcp_offset)
        self._tcp.position, self._tcp.wxyz = pos, wxyz
        s = ctl.settings
        self._boundary.visible = bool(s.boundary_on)
        if s.boundary_on:
            centre, size = scene.boundary_box(s.boundary)
            self._boundary.position = centre
            self._boundary.scale = size
        self._draw("devices", self._device_parts(), TOOL_COLOR, 1.0, True)
        track = self.emulator.linear_track
        self._draw("track", [] if track is None else scene.track_parts(track.length, track.position),
                   TRACK_COLOR, 1.0, True)
        self._draw("contact", scene.contact_parts(contact.scene_of(ctl).shapes), CONTACT_COLOR, 0.4, True)
        if self.emulator.physics is not None:
            cell = self.emulator.physics.cell
            if cell is not None:
                self._draw("cell", scene.cell_parts(cell.cell, cell.status()), CONTACT_COLOR, 0.6, True)
            objs = self.emulator.physics.world.listed_specs()
            self._draw("objects", scene.object_parts([(o.name, o.shape, o.size, o.color) for o in objs],
                                                     self.emulator.scene_objects()), OBJECT_COLOR, 1.0, True)
        if self.pendant is not None and self.updates % PANEL_EVERY == 0:
            self.pendant.update()
        self.updates += 1

    def _device_parts(self) -> list[scene.Part]:
        """The end devices attached: the vacuum cup, else the xArm gripper once it is used."""
        emu = self.emulator
        q = emu.controller.q
        sensor = scene.ft_sensor_parts(emu.model, q, ft_sensor.SENSOR_HEIGHT) if emu.has_ft_sensor else []
        if emu.vacuum is not None:
            return sensor + scene.vacuum_parts(emu.model, q)
        if emu.gripper_kind in scene.GRIPPER_SHAPES:
            return sensor + scene.end_gripper_parts(emu.model, q, emu.gripper_kind,
                                                    emu.gripper_status()["opening_mm"])
        g = emu.gripper.gripper
        if g.enabled or g.position > 0.0:
            return sensor + scene.gripper_parts(emu.model, q, g.position)
        return sensor

    def _draw(self, group: str, parts: list[scene.Part], color: tuple[int, int, int], opacity: float,
              visible: bool) -> None:
        seen = set()
        for part in parts:
            key = f"{self._root}/{group}/{part.name}"
            seen.add(key)
            handle = self._handles.get(key)
            tint = part.color or (TOOL_COLOR if "tool" in part.name else color)
            size = (part.radius, part.length, part.half)
            if handle is None or self._sizes.get(key) != size:
                if handle is not None:
                    handle.remove()
                handle = self._create(key, part, tint, opacity)
                self._handles[key] = handle
                self._sizes[key] = size
                self._colors[key] = tint
            elif self._colors.get(key) != tint:
                handle.color = tint
                self._colors[key] = tint
            handle.position, handle.wxyz, handle.visible = part.position, part.wxyz, visible
        prefix = f"{self._root}/{group}/"
        for key in [k for k in self._handles if k.startswith(prefix) and k not in seen]:
            self._handles.pop(key).remove()
            self._sizes.pop(key, None)
            self._colors.pop(key, None)

    def _create(self, key: str, part: scene.Part, color: tuple[int, int, int], opacity: float) -> Any:
        sc = self.server.scene
        op = None if opacity >= 1.0 else opacity
        if part.kind == "capsule":
            mesh_key = ("capsule", round(part.radius, 6), round(part.length, 6))
            if mesh_key not in self._meshes:
                self._meshes[mesh_key] = scene.capsule_mesh(part.radius, part.length)
            verts, faces = self._meshes[mesh_key]
            return sc.add_mesh_simple(key, verts, faces, color=color, opacity=op)
        h = part.half
        return sc.add_box(key, color=color, dimensions=(2 * h[0], 2 * h[1], 2 * h[2]), opacity=op)

    def stop(self) -> None:
        self._cancel()
        if self._owns:
            _stop_viser(self.server)


def _stop_viser(vs: Any) -> None:
    """Stop a viser server without holding up the emulator's own close: once a browser has been
    connected, its stop waits 6 s for its own event loop to wind down, so it runs in a thread of its
    own that nothing waits for (the loop ends on its own)."""

    def stop() -> None:
        with contextlib.suppress(Exception):
            vs.stop()

    threading.Thread(target=stop, name="viser-stop", daemon=True).start()


def _new_viser(host: str, port: int) -> Any:
    try:
        import viser
    except ImportError as exc:  # the "view" extra
        raise RuntimeError("the 3D view needs viser: pip install 'xarm-emu[view]'") from exc
    if not 0 <= port <= 65535:
        raise ValueError(f"--view-port must be 0..65535, got {port}")
    vs = viser.ViserServer(host=host, port=port, label="xarm-emu", verbose=False)
    # Lit by viser's default lights and a hemisphere light, without its default image-based lighting
    # and shadow maps. That HDR environment map is pre-filtered in the browser on the first frame
    # with a lit mesh: tens of seconds of a software-rendering browser's main thread during which
    # every later picture (the red arm of an error) waits. The shadow maps (three cascades drawn
    # before each frame) hold the first paint of the page, the status panel's too, about 0.6 s
    # longer. The flat colours need neither.
    vs.scene.configure_environment_map(hdri=None)
    vs.scene.configure_default_lights(enabled=True, cast_shadow=False)
    vs.scene.add_light_hemisphere("/light", sky_color=(255, 255, 255), ground_color=(120, 120, 130),
                                  intensity=HEMISPHERE_LIGHT)
    return vs


FLEET_SPACING = 0.9  # m between the arms of a fleet view, along y


class FleetView(_Redrawing):
    """One viser server for every arm of a fleet: the arms side by side along y, a list of them
    (model, command port, state, error), and a tab with each arm's pendant."""

    def __init__(self, servers: list[EmulatorServer], host: str = "127.0.0.1", port: int = 8080) -> None:
        self.server = _new_viser(host, port)
        self.host = host
        self.port = int(self.server.get_port())
        self.servers = servers
        self.updates = 0
        self._task: asyncio.Task[None] | None = None
        vs = self.server
        n = len(servers)
        vs.initial_camera.position = (1.6, -1.2 - 0.5 * FLEET_SPACING * n, 1.2)
        vs.initial_camera.look_at = (0.15, 0.5 * FLEET_SPACING * (n - 1), 0.25)
        vs.scene.add_grid("/ground", width=2.0, height=2.0 + FLEET_SPACING * n, cell_size=0.1,
                          position=(0.0, 0.5 * FLEET_SPACING * (n - 1), 0.0))
        with vs.gui.add_folder("Fleet", order=-1):
            self._list = vs.gui.add_markdown("")
        tabs = vs.gui.add_tab_group(order=0)
        self.viewers: list[Viewer] = []
        for i, srv in enumerate(servers):
            root = f"/arm{i + 1}"
            vs.scene.add_frame(root, position=(0.0, i * FLEET_SPACING, 0.0), show_axes=False)
            vs.scene.add_label(f"{root}/label", self._name(i), position=(0.0, 0.0, 0.9))
            with tabs.add_tab(f"Arm {i + 1}"):
                self.viewers.append(Viewer(srv.emulator, server=srv, viser_server=vs, root=root))

    def _name(self, i: int) -> str:
        srv = self.servers[i]
        port = srv.ports.get("command", srv.config.port)
        return f"arm {i + 1}: {srv.emulator.model.name} on {srv.config.host}:{port}"

    def listing(self) -> str:
        """The fleet's list: one line per arm with its state and error (section 3.2.1)."""
        lines = []
        for i, srv in enumerate(self.servers):
            snap = srv.emulator.snapshot()
            text = describe_state(snap)
            lines.append(f"- **{self._name(i)}**: state {text['state']}, error {text['error'].split(':')[0]}")
        return "\n".join(lines)

    def pendants(self) -> list[Pendant]:
        return [p for v in self.viewers for p in v.pendants()]

    def update(self) -> None:
        for v in self.viewers:
            v.update()
        if self.updates % PANEL_EVERY == 0:
            text = self.listing()
            if text != self._list.content:
                self._list.content = text
        self.updates += 1

    def stop(self) -> None:
        self._cancel()
        _stop_viser(self.server)


def attach_fleet_view(servers: list[EmulatorServer], host: str, port: int) -> None:
    """Serve one :class:`FleetView` of ``servers`` (all in one event loop), attached to the first so
    that it starts once the ports are open and stops with the fleet."""
    if servers:
        servers[0].attach("view", lambda: FleetView(servers, host, port))


def attach_viewer(server: EmulatorServer) -> None:
    """When ``server.config.view`` is set, have the server start a :class:`Viewer` of its emulator on
    ``view_host``/``view_port`` once its ports are open (and stop it on close)."""
    cfg = server.config
    if cfg.view:
        server.attach("view", lambda: Viewer(server.emulator, cfg.view_host, cfg.view_port, server=server))
