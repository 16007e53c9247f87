"""``xarm-emu scene``, ``scene-place`` and ``scene-reset``: the objects of a running emulator's physics
world through its admin channel (``serve --admin --scene FILE`` with ``[[object]]`` tables)."""

from __future__ import annotations

import json
from typing import Annotated, Any

import typer
from rich.table import Table

from ..protocol.frame import COMMAND_PORT
from .options import AdminPortOpt, HostOpt, PortOpt, admin, console


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
