"""``xarm-emu scene``, ``scene-place``, ``scene-reset``, ``scene-add`` and ``scene-remove``: the objects
and cell elements of a running emulator's physics world through its admin channel (``serve --admin``;
``--scene FILE`` with ``[[object]]`` or cell tables)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from ..protocol.frame import COMMAND_PORT
from ..tomlfile import read_toml
from .options import AdminPortOpt, HostOpt, PortOpt, admin, console, err_console


def scene(as_json: Annotated[bool, typer.Option("--json", help="One JSON object, for programs.")] = False,
          host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
          admin_port: AdminPortOpt = None) -> None:
    """Every object's pose (mm, deg, base frame) and whether the hand holds it, and the cell's
    conveyors, sensors and feeders with their state (admin channel)."""
    message = admin(host, port, admin_port, "scene-objects")
    data: dict[str, Any] = json.loads(message)
    if as_json:
        print(json.dumps(data))
        return
    table = Table(title=f"objects at t = {data['time']:.3f} s")
    for col in ("name", "x", "y", "z", "roll", "pitch", "yaw", "held"):
        table.add_column(col)
    for o in data["objects"]:
        table.add_row(o["name"], *(f"{v:.2f}" for v in (*o["position"], *o["rpy"])),
                      "yes" if o["held"] else "no")
    console.print(table)
    for key, cols, row in (
            ("conveyors", ("conveyor", "running", "speed mm/s", "output"),
             lambda e: (e["name"], "yes" if e["running"] else "no", f"{e['speed']:g}",
                        e["output"] or "always")),
            ("sensors", ("sensor", "interrupted", "input", "level"),
             lambda e: (e["name"], "yes" if e["interrupted"] else "no", e["input"], str(e["level"]))),
            ("feeders", ("feeder", "placed", "of"), lambda e: (e["name"], str(e["count"]), str(e["of"])))):
        if data.get(key):
            t = Table()
            for col in cols:
                t.add_column(col)
            for e in data[key]:
                t.add_row(*row(e))
            console.print(t)


def scene_place(name: Annotated[str, typer.Argument(help="The object's name in the scene file.")],
                x: float, y: float, z: float,
                roll: Annotated[float, typer.Argument(help="deg")] = 0.0,
                pitch: Annotated[float, typer.Argument(help="deg")] = 0.0,
                yaw: Annotated[float, typer.Argument(help="deg")] = 0.0,
                host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
                admin_port: AdminPortOpt = None) -> None:
    """Put an object at x y z (mm, base frame) turned by roll pitch yaw (deg), at rest."""
    admin(host, port, admin_port, "scene-place", name=name, position=[x, y, z], rpy=[roll, pitch, yaw])


def scene_reset(host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
                admin_port: AdminPortOpt = None) -> None:
    """Every object back where the scene file puts it, at rest."""
    admin(host, port, admin_port, "scene-reset")


def scene_add(file: Annotated[Path, typer.Argument(help="A TOML file of scene tables to add "
                                                        "([[object]], [[conveyor]], [[sensor]], ...).")],
              host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
              admin_port: AdminPortOpt = None) -> None:
    """Add the file's objects and cell elements (and planes, boxes) to the running scene: the engine
    is rebuilt, what is already there goes on where it is, the arm is untouched."""
    try:
        tables = read_toml(file, ValueError, "scene file")
    except ValueError as exc:
        err_console.print(str(exc))
        raise typer.Exit(2) from None
    admin(host, port, admin_port, "scene-add", tables=tables)


def scene_remove(name: Annotated[str, typer.Argument(help="The element's name in the scene.")],
                 host: HostOpt = "127.0.0.1", port: PortOpt = COMMAND_PORT,
                 admin_port: AdminPortOpt = None) -> None:
    """Take an object, conveyor, sensor, feeder, plane or box out of the running scene."""
    admin(host, port, admin_port, "scene-remove", name=name)
