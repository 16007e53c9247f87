"""The register pages: one per firmware profile the CLI accepts, each register with its request and
reply layout (every alternative form), flags, manual section and the version it appears in; and an
index of which profile answers which register."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..cli.reference import register_record
from ..protocol.firmware import SUPPORTED_VERSIONS, FirmwareProfile, first, profile_for
from ..protocol.registers import LATER_FORMS, Register, all_registers, registers_for
from .markdown import cell, code, table

__all__ = ["index_page", "listed", "page_path", "pages", "profile_page"]


def page_path(version: str) -> str:
    """Where the register page of firmware ``version`` goes."""
    return f"reference/registers/firmware-{version}.md"


def pages() -> list[tuple[str, str, str]]:
    """The index, then one page per supported firmware version (oldest first)."""
    out = [("reference/registers/index.md", "Registers", index_page())]
    for version in SUPPORTED_VERSIONS:
        out.append((page_path(version), f"Firmware {version}", profile_page(profile_for(version))))
    return out


def index_page() -> str:
    """Every register of any profile against every profile: the version it appears in, and where its
    layout changes."""
    tables = {v: registers_for(profile_for(v)) for v in SUPPORTED_VERSIONS}
    header = ["register", "name", "since", *(f"[{v}](firmware-{v}.md)" for v in SUPPORTED_VERSIONS)]
    rows = []
    for code_, reg in sorted(all_registers().items()):
        marks = []
        for v in SUPPORTED_VERSIONS:
            at = tables[v].get(code_)
            marks.append("" if at is None else f"[yes](firmware-{v}.md#r{code_})")
        rows.append([str(code_), code(reg.name), reg.since, *marks])
    return "\n".join([
        "# Registers",
        "",
        "The command port's registers (manual 2.1.3 and 2.1.4, protocol ids 2 and 3) as the emulator's "
        "register table holds them. A box claims a firmware version in register 1 and the official SDK "
        "switches its code paths on that claim; the emulator answers the registers and layouts of the "
        "version it claims (`xarm-emu serve --firmware`). Each version below has a page of its own; "
        "`xarm-emu registers --firmware VERSION [--json]` prints the same table.",
        "",
        "Byte orders (manual 2.1.2): fp32 and int32 little-endian, u16 and u32 big-endian. A reply's "
        "parameters follow its state byte.",
        "",
        table(header, rows),
    ])


def profile_page(profile: FirmwareProfile) -> str:
    """The page of one firmware profile: what the profile switches, a summary of its registers, then
    each register in full."""
    regs = registers_for(profile)
    version = str(profile)
    parts = [
        f"# Registers at firmware {version}",
        "",
        f"{len(regs)} registers answer on the command port of a box that claims firmware {version} "
        f"(`xarm-emu serve --firmware {version}`, `xarm-emu registers --firmware {version}`).",
        "",
        "## What this version switches",
        "",
        _switches(profile),
        "## Summary",
        "",
        table(["register", "name", "title", "manual", "since", "flags"],
              ([f"[{r.code}](#r{r.code})", code(r.name), cell(r.title), cell(r.section), r.since,
                cell(", ".join(register_record(r)["flags"]))] for r in regs.values())),
    ]
    parts += [_register(r, _changed(profile, r.code)) for r in regs.values()]
    return "\n".join(parts)


def _switches(profile: FirmwareProfile) -> str:
    """Every property of the profile (each an SDK version threshold) with its value here."""
    rows = []
    for name, attr in vars(FirmwareProfile).items():
        if not isinstance(attr, property) or name.startswith("_"):
            continue
        doc = (attr.__doc__ or "").strip().replace("\n", " ")
        rows.append([code(name), code(getattr(profile, name)), cell(" ".join(doc.split()))])
    return table(["property", "value", "meaning"], rows)


def _changed(profile: FirmwareProfile, code_: int) -> list[str]:
    """The versions up to ``profile`` whose later form of register ``code_`` (LATER_FORMS) applies."""
    return [first(has_form) for has_form, c, _ in LATER_FORMS if c == code_ and getattr(profile, has_form)]


def _register(reg: Register, changed: list[str]) -> str:
    rec = register_record(reg)
    head = [f"## {reg.code} {reg.name} {{#r{reg.code}}}", "", f"**{cell(reg.title)}**", "",
            f"Manual section {cell(reg.section)}; answered from firmware {reg.since}."]
    if changed:
        head[-1] += " Layout or flags as changed at firmware " + ", ".join(dict.fromkeys(changed)) + "."
    if rec["flags"]:
        head[-1] += " Flags: " + ", ".join(rec["flags"]) + "."
    if reg.doc:
        head += ["", cell(reg.doc)]
    head += ["", _layout("Request", rec["request"]), _layout("Reply", rec["reply"])]
    return "\n".join(head)


def _layout(what: str, options: list[dict[str, Any]]) -> str:
    if len(options) == 1 and not options[0]["fields"] and not options[0]["rest"]:
        return f"{what}: no parameters.\n"
    out = []
    for n, opt in enumerate(options, start=1):
        sizes = ", ".join(str(s) for s in opt["sizes"])
        title = f"{what}" + (f", form {n} of {len(options)}" if len(options) > 1 else "")
        unit = "byte" if opt["sizes"] == [1] else "bytes"
        tail = ""
        if opt["rest"]:
            least = f" (at least {opt['rest_min']})" if opt["rest_min"] else ""
            tail = f", then raw `{opt['rest']}` bytes{least}"
        note = f" ({sizes} {unit}{tail})"
        out.append(f"*{title}*{note}" + (":\n" if opt["fields"] else ".\n"))
        if opt["fields"]:
            out.append(table(["field", "type", "count", "bytes", "optional", "meaning"],
                             ([code(f["name"]), f["type"], f["count"], f["bytes"],
                               "yes" if f["optional"] else "", cell(f["doc"])] for f in opt["fields"])))
    return "\n".join(out)


def listed(page: str) -> Mapping[int, str]:
    """The registers a generated page lists in full, by code (its ``{#rN}`` headings)."""
    import re

    return {int(m.group(2)): m.group(1) for m in re.finditer(r"^## \d+ (\S+) \{#r(\d+)\}$", page, re.M)}
