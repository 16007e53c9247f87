"""The reference pages of the code's smaller tables: error and warning codes (protocol/codes.py), the
standard Modbus-TCP map (protocol/modbus.py), each device's register map (controller/devices/, in the
form of protocol/regmap.py) and the keys of the TOML files, read from the key sets their readers check
(tomlfile.check_keys)."""

from __future__ import annotations

import importlib
import pkgutil
import sys
from collections.abc import Iterator
from types import ModuleType

from ..protocol import codes, regmap
from .markdown import cell, code, docstring, table

__all__ = ["CODE_TABLES", "codes_page", "device_maps", "devices_page", "file_keys", "files_page",
           "modbus_page"]

#: The code tables of the codes page, each with its title and what reads it.
CODE_TABLES: tuple[tuple[str, str, dict[int, codes.Code]], ...] = (
    ("Control box errors (manual 3.2.1)", "register 15's error byte and the reports",
     codes.CONTROLLER_ERRORS),
    ("Control box warnings (manual 3.2.2)", "register 15's warning byte", codes.WARNINGS),
    ("Joint (servo) errors (manual 3.1)", "register 106 and the rich report, per joint", codes.SERVO_ERRORS),
    ("xArm Gripper errors (manual 3.3)", "the gripper's error register over register 124",
     codes.GRIPPER_ERRORS),
    ("Robotiq 2F-85 / 2F-140 faults", "gFLT of the gripper's status over register 124", codes.ROBOTIQ_FAULTS),
    ("BIO gripper errors", "the gripper's error register 0x000F over register 124", codes.BIO_GRIPPER_ERRORS),
)


def codes_page() -> tuple[str, str, str]:
    parts = ["# Error and warning codes", "",
             "The codes the emulator raises and reports, with the handling the manual gives the operator "
             "(`xarm-emu codes` prints them; `xarm-emu codes C31` explains one). Codes marked *restart* are "
             "cleared by a power cycle: the control box emergency-stop button, then enabling again.", "",
             f"A control box error the table does not list: {cell(codes.UNLISTED_HANDLING)}", ""]
    for title, source, entries in CODE_TABLES:
        parts += [f"## {title}", "", f"Read from {source}.", "",
                  table(["code", "name", "handling", "restart"],
                        ([f"**{e.label}**", cell(e.name), cell(e.handling), "yes" if e.restart else ""]
                         for e in entries.values()))]
    return "reference/codes.md", "Error and warning codes", "\n".join(parts)


def modbus_page() -> tuple[str, str, str]:
    from ..protocol import modbus

    rows = []
    for p in modbus.MODBUS_MAP:
        span = str(p.address) if p.count == 1 else f"{p.address}-{p.end - 1}"
        scale = "" if p.scale == 1 else f"x{p.scale:g}"
        rows.append([p.kind.value, span, code(p.name), cell(p.unit), scale + (" signed" if p.signed else ""),
                     "rw" if p.writable else "r", cell(p.writes), cell(p.doc)])
    text = "\n".join(["# Standard Modbus-TCP map", "",
                      "Protocol id 0 on the command port (or `serve --modbus-port`), unit 1: every point of "
                      "the published PLC map, with its scaling (wire value = engineering value x scale) and "
                      "the private register a write is equivalent to (`xarm-emu modbus-map` prints it).", "",
                      table(["table", "addresses", "name", "unit", "scale", "access", "as register", "note"],
                            rows),
                      "## Notes from the table's module", "", docstring(modbus.__doc__)])
    return "reference/modbus.md", "Standard Modbus-TCP map", text


def device_maps() -> Iterator[tuple[ModuleType, regmap.RegisterMap]]:
    """Every module of controller/devices/ with a ``REGISTER_MAP``, in name order."""
    from ..controller import devices

    for info in sorted(pkgutil.iter_modules(devices.__path__), key=lambda i: i.name):
        module = importlib.import_module(f"{devices.__name__}.{info.name}")
        regs = getattr(module, "REGISTER_MAP", None)
        if isinstance(regs, dict) and regs:
            yield module, regs


def devices_page() -> tuple[str, str, str]:
    parts = ["# Device registers", "",
             "The Modbus-RTU registers of the devices on the tool and control box RS-485 buses, which "
             "register 124 reaches (manual 2.1.4). Registers are u16, big-endian. A read of an address a "
             "map lacks, or of a write-only register, is exception 2; a written value outside the range "
             "is exception 3.", ""]
    for module, regs in device_maps():
        title = (module.__doc__ or module.__name__).strip().splitlines()[0].rstrip(".")
        name = module.__name__.rsplit(".", 1)[-1]
        parts += [f"## {cell(title)} {{#{name.replace('_', '-')}}}", "", f"Module `{module.__name__}`.", "",
                  table(["address", "field", "access", "accepts", "unit", "scale", "block"],
                        ([f"`0x{a:04X}` ({a})", code(r.field), r.access, _accepts(r), cell(r.unit),
                          "" if r.scale == 1 else f"{r.scale:g}", "" if r.block == 1 else r.block]
                         for a, r in sorted(regs.items())))]
    return "reference/devices.md", "Device registers", "\n".join(parts)


def _accepts(r: regmap.Reg) -> str:
    if r.range is None:
        return ""
    return f"{r.range[0]}..{r.range[1]}" + ("" if r.keep is None else f" or {r.keep} (keep)")


def file_keys() -> list[tuple[str, str, str, list[tuple[str, str, str]]]]:
    """The TOML files and their keys: (title, option, module name, [(table, key, note)]), every key
    read from the set its reader checks."""
    from ..controller.scene import cell, contact, objects
    from ..fidelity import compare
    from ..model import calibration
    from ..server import faults, fleet

    scene = [(f"[[{kind}]]", key, "") for kind, keys in contact.SHAPE_KEYS.items() for key in sorted(keys)]
    scene += [("[[object]]", key, "") for key in sorted(objects.KEYS)]
    scene += [(f"[[{kind}]]", key, "") for kind, keys in cell.KEYS.items() for key in sorted(keys)]
    fault = [("[[fault]]", key, "") for key in ("at", "after", "do")]
    fault += [("[[fault]]", arg, f'do = "{do}"') for do, args in faults.ARGUMENTS.items() for arg in args]
    fleet_keys = [("top level", k, "default for every arm" if k in fleet.ARM_KEYS else "")
                  for k in fleet.TOP_KEYS]
    fleet_keys += [("[[arm]]", k, "") for k in fleet.ARM_KEYS]
    cal = [("[uncertainty]" if k == "uncertainty" else "top level", k, "") for k in calibration.KEYS]
    tol = [("top level", k, f"default {v:g}") for k, v in compare.DEFAULT_TOLERANCES.items()]
    return [
        ("Scene files", "serve --scene FILE", contact.__name__, scene),
        ("Fault schedules", "serve --faults FILE", faults.__name__, fault),
        ("Fleet files", "serve --fleet FILE", fleet.__name__, fleet_keys),
        ("Calibration files", "serve --calibration FILE, calibrate -o FILE", calibration.__name__, cal),
        ("Tolerance files", "compare --tolerances FILE", compare.__name__, tol),
    ]


def files_page() -> tuple[str, str, str]:
    from ..server.faults import AFTER

    parts = ["# File keys", "",
             "The keys each TOML file takes, read from the key sets its reader checks: any other key is "
             "refused with one line naming the file, the table and the key, before any port opens.", ""]
    for title, option, module_name, keys in file_keys():
        parts += [f"## {title}", "", f"`xarm-emu {option}`, read by `{module_name}`.", "",
                  table(["table", "key", "note"], ([cell(t), code(k), cell(n)] for t, k, n in keys))]
        if title == "Fault schedules":
            parts += [f"`after` is one of {', '.join(f'`{a}`' for a in AFTER)}.", ""]
        doc = sys.modules[module_name].__doc__
        if doc:
            parts += ['??? note "From the module\'s documentation"', "",
                      "\n".join("    " + line if line else "" for line in docstring(doc).splitlines()), ""]
    return "reference/files.md", "File keys", "\n".join(parts)
