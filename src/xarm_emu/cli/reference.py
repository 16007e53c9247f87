"""``registers``, ``modbus-map`` and ``codes``: the manual's tables as the emulator itself holds them
(register layouts of sections 2.1.3 and 2.1.4, the standard Modbus-TCP map, the codes of chapter 3)."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Annotated, Any

import typer
from rich.table import Table

from ..protocol import codes
from ..protocol.firmware import DEFAULT_VERSION
from ..protocol.layouts import Layout
from ..protocol.registers import Register
from .options import console, err_console, user_error


def register_record(reg: Register) -> dict[str, Any]:
    """One register as plain data (``registers --json`` and the documentation site): code, names,
    manual section, the firmware version it appears in, flags, and each request and reply layout as a
    list of alternative forms, each a list of fields (name, wire type, count, bytes, optional, doc)."""
    return {"code": reg.code, "name": reg.name, "title": reg.title, "section": reg.section,
            "since": reg.since, "flags": flag_names(reg), "request": _layout_record(reg.request),
            "reply": _layout_record(reg.reply), "doc": reg.doc}


def flag_names(reg: Register) -> list[str]:
    """The register's flags in words (``queued``, ``system reset``, ...)."""
    return [f.name.lower().replace("_", " ") for f in type(reg.flags) if f in reg.flags and f.name]


def _layout_record(layout: Layout) -> list[dict[str, Any]]:
    options: tuple[Layout, ...] = getattr(layout, "options", None) or (layout,)
    return [{"fields": [{"name": f.name, "type": f.kind, "count": f.count, "bytes": f.size,
                         "optional": i >= o.n_required, "doc": f.doc} for i, f in enumerate(o.fields)],
             "rest": o.rest, "rest_min": o.rest_min, "sizes": o.sizes(), "describe": o.describe()}
            for o in options]


def register_table(firmware: str) -> Mapping[int, Register]:
    """The register table a box of ``firmware`` answers (exit 2 for a version the CLI does not take)."""
    from ..protocol.firmware import VersionError, profile_for
    from ..protocol.registers import registers_for

    try:
        return registers_for(profile_for(firmware))
    except VersionError as exc:
        user_error(f"--firmware: {exc}")


def registers(
    code: Annotated[int | None, typer.Argument(help="One register, e.g. 21.")] = None,
    firmware: Annotated[str, typer.Option(help="The firmware profile whose table to show: "
                                               f"{DEFAULT_VERSION} is the manual's box; later versions add "
                                               "registers and forms.")]
    = DEFAULT_VERSION,
    as_json: Annotated[bool, typer.Option("--json", help="One JSON object per register.")] = False,
) -> None:
    """List the registers of the command port with their request and reply layouts (manual 2.1.3,
    2.1.4), read from the register table the emulator itself uses."""
    table = register_table(firmware)
    if code is not None:
        reg = table.get(code)
        if reg is None:
            err_console.print(f"no register {code} at firmware {firmware}; `xarm-emu registers` lists them")
            raise typer.Exit(2)
        if as_json:
            print(json.dumps(register_record(reg)))
            return
        console.print(f"{reg.code} {reg.name}: {reg.title} (manual {reg.section})")
        console.print(f"  request: {reg.request.describe()}")
        console.print(f"  reply:   {reg.reply.describe()}")
        flags = flag_names(reg)
        if flags:
            console.print(f"  flags:   {', '.join(flags)}")
        if reg.doc:
            console.print(f"  {reg.doc}")
        from ..controller.handlers import handled_by

        for line in handled_by(code):
            console.print(f"  {line}", soft_wrap=True)
        return
    if as_json:
        for reg in table.values():
            print(json.dumps(register_record(reg)))
        return
    # Plain lines (one per register), easy to grep: code, name, title; request -> reply.
    print("# command port registers: fp32/int32 little-endian, u16 big-endian (manual 2.1.2)")
    for reg in table.values():
        print(f"{reg.code:3d} {reg.name:26s} {reg.title}\n    request: {reg.request.describe()}"
              f"\n    reply:   {reg.reply.describe()}")


def modbus_map(
    as_json: Annotated[bool, typer.Option("--json", help="One JSON object per point.")] = False,
) -> None:
    """Print the standard Modbus-TCP map (protocol id 0, unit 1): every point, its scaling and what a
    write does, from the emulator's own table."""
    from ..protocol.modbus import MODBUS_MAP

    if as_json:
        for p in MODBUS_MAP:
            console.print(json.dumps({"table": p.kind.value, "address": p.address, "count": p.count,
                                      "name": p.name, "unit": p.unit, "scale": p.scale, "signed": p.signed,
                                      "writable": p.writable, "writes": p.writes, "doc": p.doc}),
                          soft_wrap=True)
        return
    rows = []
    for p in MODBUS_MAP:
        span = str(p.address) if p.count == 1 else f"{p.address}-{p.end - 1}"
        note = "; ".join(x for x in (p.writes and f"as register {p.writes}", p.doc) if x)
        rows.append((p.kind.value, span, p.name, p.unit,
                     "" if p.scale == 1 else f"x{p.scale:g}" + (" signed" if p.signed else ""),
                     "rw" if p.writable else "r", note))
    if console.width < 120:  # narrow or piped: a list, each point's note wrapped under it
        import textwrap

        for kind, span, name, unit, scale, rw, note in rows:
            head = " ".join(x for x in (kind, span, name, rw, unit and f"[{unit}]", scale) if x)
            console.print(head, soft_wrap=True)
            for line in textwrap.wrap(note, width=max(40, console.width - 4)):
                console.print("    " + line, soft_wrap=True)
        return
    table = Table("table", "addresses", "name", "unit", "scale", "rw", "note")
    for col in table.columns[1:3]:  # addresses and names stay whole
        col.no_wrap = True
    for row in rows:
        table.add_row(*row)
    console.print(table)


def show_codes(
    label: Annotated[str | None, typer.Argument(help="One code, e.g. C31, W11, S23 or G11; a bare number "
                                                     "(31) is the control box error and warning of that "
                                                     "number, as registers 15 answers them.")] = None,
) -> None:
    """List the error and warning codes of manual chapter 3 with their handling, or explain one."""
    if label is not None:
        _explain_code(label)
        return
    for title, table in (("Control box errors (3.2.1)", codes.CONTROLLER_ERRORS),
                         ("Warnings (3.2.2)", codes.WARNINGS),
                         ("Joint (servo) errors (3.1)", codes.SERVO_ERRORS),
                         ("Gripper errors (3.3)", codes.GRIPPER_ERRORS)):
        t = Table(title=title)
        t.add_column("code")
        t.add_column("name")
        t.add_column("handling")
        for entry in table.values():
            t.add_row(entry.label, entry.name, entry.handling)
        console.print(t)


def _explain_code(label: str) -> None:
    """``codes C31`` or ``codes 31`` (the control box error, then the warning, of that number)."""
    text = label.strip()
    if text.isdigit():
        found = [e for e in (codes.lookup("C", int(text)), codes.lookup("W", int(text))) if e is not None]
        if not found:
            user_error(f"{text} is neither a control box error nor a warning of the manual (3.2.1, 3.2.2)")
        for entry in found:
            console.print(entry.describe())
        return
    try:
        console.print(codes.parse_label(text).describe())
    except ValueError as exc:
        user_error(str(exc))


