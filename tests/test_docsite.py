"""The documentation site's generated reference (xarm_emu.docsite, docs/hooks/reference.py): every
register that `xarm-emu registers --json` lists per firmware profile, every code, Modbus point, device
register, file key and CLI command and option is on its page, and a register added to the table appears
without editing a page. The full `make docs` build (about 13 s here) runs in CI, not in these tests."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import markdown
import pytest
from typer.testing import CliRunner

from xarm_emu import cli, docsite
from xarm_emu.docsite import registers as reg_pages
from xarm_emu.docsite import tables
from xarm_emu.docsite.cli import command, command_names
from xarm_emu.protocol import codes, modbus
from xarm_emu.protocol import registers as table
from xarm_emu.protocol.firmware import SUPPORTED_VERSIONS, first, profile_for

ROOT = Path(__file__).resolve().parent.parent
runner = CliRunner()


def _registers_json(*args: str) -> list[dict]:
    result = runner.invoke(cli.app, ["registers", "--json", *args])
    assert result.exit_code == 0, result.output
    return [json.loads(line) for line in result.output.splitlines()]


def _section(page: str, heading: str) -> str:
    """The text of ``page`` from the heading line ``heading`` to the next heading of its level."""
    level = heading.split(" ", 1)[0]
    start = page.index(heading + "\n")
    nxt = re.search(rf"^{level} ", page[start + len(heading):], re.M)
    return page[start:] if nxt is None else page[start:start + len(heading) + nxt.start()]


@pytest.mark.parametrize("version", SUPPORTED_VERSIONS)
def test_each_profile_page_lists_every_register_that_registers_json_lists(version: str) -> None:
    listed = _registers_json("--firmware", version)
    page = reg_pages.profile_page(profile_for(version))
    assert reg_pages.listed(page) == {r["code"]: r["name"] for r in listed}
    for r in listed:  # the layouts and since-version of each, in its own section
        text = _section(page, f"## {r['code']} {r['name']} {{#r{r['code']}}}")
        assert f"answered from firmware {r['since']}" in text
        later = [first(has_form) for has_form, c, _ in table.LATER_FORMS if c == r["code"]
                 and getattr(profile_for(version), has_form)]
        assert ("as changed at firmware " + ", ".join(dict.fromkeys(later)) in text) == bool(later)
        for form in r["request"] + r["reply"]:
            for f in form["fields"]:
                assert f"| `{f['name']}` | {f['type']} | {f['count']} | {f['bytes']} |" in text


def test_the_index_marks_which_profile_answers_which_register() -> None:
    page = reg_pages.index_page()
    answered = {v: {r["code"] for r in _registers_json("--firmware", v)} for v in SUPPORTED_VERSIONS}
    rows = {int(m.group(1)): m.group(0) for m in re.finditer(r"^\| (\d+) \|.*$", page, re.M)}
    assert set(rows) == set().union(*answered.values())
    for code, row in rows.items():
        for v in SUPPORTED_VERSIONS:
            assert (f"(firmware-{v}.md#r{code})" in row) == (code in answered[v]), (code, v)


def test_a_register_added_to_the_table_appears_on_the_pages_of_its_versions(
        monkeypatch: pytest.MonkeyPatch) -> None:
    new = replace(table.EXTRA_REGISTERS[0], code=249, name="DOCS_PROBE", title="A register for this test",
                  since="2.4.101", doc="Added by the test <only>.")
    monkeypatch.setattr(table, "EXTRA_REGISTERS", (*table.EXTRA_REGISTERS, new))
    table.registers_for.cache_clear()
    try:
        for version in SUPPORTED_VERSIONS:
            page = reg_pages.profile_page(profile_for(version))
            expected = profile_for(version).version.at_least("2.4.101")
            assert (reg_pages.listed(page).get(249) == "DOCS_PROBE") == expected, version
            assert ("Added by the test &lt;only&gt;." in page) == expected
        assert "| 249 | `DOCS_PROBE` | 2.4.101 |" in reg_pages.index_page()
    finally:
        monkeypatch.undo()
        table.registers_for.cache_clear()
    assert 249 not in reg_pages.listed(reg_pages.profile_page(profile_for(SUPPORTED_VERSIONS[-1])))


def test_registers_json_and_firmware_options() -> None:
    assert len(_registers_json()) == len(table.REGISTERS)  # 1.6.0, the manual's box, by default
    newest = _registers_json("--firmware", SUPPORTED_VERSIONS[-1])
    assert {r["code"] for r in newest} == set(table.all_registers())
    one = _registers_json("21", "--firmware", "2.7.103")
    assert len(one) == 1 and one[0]["since"] == "1.6.0" and "inf unchanged" in one[0]["flags"]
    assert [sum(f["bytes"] for f in form["fields"]) for form in one[0]["request"]][0] == 36  # manual 2.1.3
    assert len(one[0]["request"]) == 2  # and the 'common' form of firmware 1.11.100 on
    refused = runner.invoke(cli.app, ["registers", "253"])  # a 2.x register, not at 1.6.0
    assert refused.exit_code == 2 and "no register 253 at firmware 1.6.0" in refused.output
    bad = runner.invoke(cli.app, ["registers", "--firmware", "9.9.9"])
    assert bad.exit_code == 2 and len(bad.output.strip().splitlines()) == 1


def test_the_codes_page_lists_every_code_of_every_code_table() -> None:
    page = tables.codes_page()[2]
    in_module = [v for v in vars(codes).values()
                 if isinstance(v, dict) and v and all(isinstance(c, codes.Code) for c in v.values())]
    shown = [entries for _, _, entries in tables.CODE_TABLES]
    assert all(any(t is s for s in shown) for t in in_module), "a code table of protocol/codes.py is missing"
    for title, _, entries in tables.CODE_TABLES:
        text = _section(page, f"## {title}")
        rows = re.findall(r"^\| \*\*([A-Z]\d+)\*\* \| ([^|]*) \|", text, re.M)
        assert rows == [(e.label, e.name) for e in entries.values()], title


def test_the_modbus_page_lists_every_point_of_the_map() -> None:
    page = tables.modbus_page()[2]
    rows = re.findall(r"^\| ([a-z ]+) \| (\d+(?:-\d+)?) \| `(\w+)` \|", page, re.M)
    assert rows == [(p.kind.value, str(p.address) if p.count == 1 else f"{p.address}-{p.end - 1}", p.name)
                    for p in modbus.MODBUS_MAP]


def test_the_devices_page_lists_every_register_of_every_device_map() -> None:
    page = tables.devices_page()[2]
    maps = list(tables.device_maps())
    names = {m.__name__.rsplit(".", 1)[-1] for m, _ in maps}
    assert {"gripper", "robotiq", "linear_track", "bio_gripper", "inspire_hand"} <= names
    for module, regs in maps:
        anchor = module.__name__.rsplit(".", 1)[-1].replace("_", "-")
        heading = next(line for line in page.splitlines() if line.endswith(f"{{#{anchor}}}"))
        row = r"^\| `0x([0-9A-F]{4})` \(\d+\) \| `([^`]+)` \| (\w+) \|"
        rows = re.findall(row, _section(page, heading), re.M)
        assert rows == [(f"{a:04X}", r.field, r.access) for a, r in sorted(regs.items())], module.__name__


def test_the_files_page_lists_the_keys_each_reader_checks() -> None:
    from xarm_emu.controller.scene import cell, contact, objects
    from xarm_emu.fidelity.compare import DEFAULT_TOLERANCES
    from xarm_emu.model import calibration
    from xarm_emu.server import faults, fleet

    page = tables.files_page()[2]

    def keys(title: str) -> set[tuple[str, str]]:
        return set(re.findall(r"^\| ([^|]+) \| `(\w+)` \|", _section(page, f"## {title}"), re.M))

    assert keys("Scene files") == ({(f"[[{k}]]", key) for k, ks in contact.SHAPE_KEYS.items() for key in ks}
                                   | {("[[object]]", key) for key in objects.KEYS}
                                   | {(f"[[{k}]]", key) for k, ks in cell.KEYS.items() for key in ks})
    assert set(contact.SHAPE_KEYS) | {"object"} | set(cell.KEYS) == set(contact.TABLES)
    arguments = {a for args in faults.ARGUMENTS.values() for a in args}
    assert keys("Fault schedules") == {("[[fault]]", k) for k in ("at", "after", "do", *arguments)}
    assert keys("Fleet files") == ({("top level", k) for k in fleet.TOP_KEYS}
                                   | {("[[arm]]", k) for k in fleet.ARM_KEYS})
    assert {k for _, k in keys("Calibration files")} == set(calibration.KEYS)
    assert keys("Tolerance files") == {("top level", k) for k in DEFAULT_TOLERANCES}


def test_the_key_sets_shown_are_the_ones_the_readers_refuse_others_by() -> None:
    from xarm_emu.controller.scene import contact
    from xarm_emu.model import calibration

    plane = {k: [0, 0, 1] for k in contact.SHAPE_KEYS["plane"] if k in ("point", "normal")}
    contact.parse_scene({"plane": [{**plane, "stiffness": 1.0, "name": "t", "damping": 0, "friction": 0}]})
    with pytest.raises(ValueError, match="unknown key 'colour'"):
        contact.parse_scene({"plane": [{**plane, "stiffness": 1.0, "colour": 1}]})
    with pytest.raises(calibration.CalibrationError, match="unknown key 'torque'"):
        calibration.from_dict({"format": calibration.FORMAT, "torque": [1.0]})
    every = {k: [1.0] * 6 for k in calibration.CONSTANTS} | {"format": calibration.FORMAT, "model": "6"}
    assert calibration.from_dict(every).model == "6"


def test_the_cli_page_shows_every_command_and_every_option() -> None:
    page = docsite.cli.page()[2]
    names = command_names()
    assert {"xarm-emu serve", "xarm-emu inject estop", "xarm-emu checkpoint save"} <= set(names)

    def walk(cmd, path: str):  # type: ignore[no-untyped-def]
        yield path, cmd
        for name, sub in getattr(cmd, "commands", {}).items():
            yield from walk(sub, f"{path} {name}")

    import typer

    checked = 0
    for path, cmd in walk(command, "xarm-emu"):
        level = "#" * (2 + path.count(" "))
        text = _section(page, f"{level} `{path}`")
        ctx = typer.Context(cmd, info_name=path)
        for param in cmd.get_params(ctx):
            record = param.get_help_record(ctx)
            if record is not None:
                assert f"* `{record[0]}`" in text, (path, record[0])
                checked += 1
    assert checked > 100 and "* `--max-connections <int range>`" in _section(page, "### `xarm-emu serve`")


def test_pages_render_and_keep_angle_brackets_visible() -> None:
    html = markdown.markdown(reg_pages.profile_page(profile_for("1.6.0")),
                             extensions=["tables", "attr_list", "toc"])
    assert "&lt;axis&gt;,&lt;type&gt;" in html  # register 1's version string, not swallowed as a tag
    assert 'id="r21"' in html and "<table>" in html


def _nav_paths(nav: object) -> list[str]:
    if isinstance(nav, str):
        return [nav]
    if isinstance(nav, dict):
        return [p for v in nav.values() for p in _nav_paths(v)]
    assert isinstance(nav, list)
    return [p for item in nav for p in _nav_paths(item)]


def test_the_hook_adds_every_generated_page_to_the_files_and_the_navigation() -> None:
    from mkdocs.config import load_config
    from mkdocs.structure.files import get_files

    config = load_config(str(ROOT / "mkdocs.yml"))  # as `mkdocs build` runs the hook: as a plugin's events
    config = config.plugins.on_config(config)
    assert config.site_name == f"xarm-emu {docsite.package_version()}"
    files = config.plugins.on_files(get_files(config), config=config)
    generated = [p for p, _, _ in docsite.pages(ROOT)]
    assert all(files.get_file_from_path(p) is not None for p in generated)
    nav = _nav_paths(config.nav)
    assert set(generated) <= set(nav)
    on_disk = {p.relative_to(ROOT / "docs").as_posix() for p in (ROOT / "docs").rglob("*.md")
               if "hooks" not in p.parts}
    assert on_disk <= set(nav), "every page of docs/ is reachable"
    tutorials = [p for p in nav if p.startswith("tutorials/")]
    numbered = sorted((ROOT / "examples").glob("[0-9][0-9]_*.py"))
    assert tutorials == [f"tutorials/{p.stem}.md" for p in numbered]


def test_the_readme_links_only_pages_that_exist() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    links = re.findall(r"\]\(((?:docs|examples)/[^)#]+)", text)
    assert links and all((ROOT / link).exists() for link in links), links
