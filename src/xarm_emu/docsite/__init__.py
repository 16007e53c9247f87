"""The documentation site's reference pages, written at build time from the code's own tables.

:func:`pages` gives every generated page as ``{path: markdown}`` (paths under the site's docs
directory); ``docs/hooks/reference.py`` hands them to MkDocs, so a register, code, device register,
CLI option or file key added to its table appears on the site without editing a page. Each page
comes from one module: :mod:`.registers` (the register table of every firmware profile),
:mod:`.tables` (codes, the standard Modbus map, the devices' register maps, the keys of the TOML
files), :mod:`.cli` (the command line, through mkdocs-click) and :mod:`.tutorials` (the numbered
examples).

This layer sits above :mod:`xarm_emu.cli`: it reads every table and imports nothing that a server or a
client runs.
"""

from __future__ import annotations

from pathlib import Path

from . import cli, registers, tables, tutorials

__all__ = ["Page", "package_version", "pages"]

#: One generated page: (path under docs/, title for the navigation, markdown).
Page = tuple[str, str, str]


def package_version() -> str:
    """The version of the installed package: ``xarm_emu.__version__`` where the package defines it,
    else the distribution's metadata (the same string either way)."""
    import xarm_emu

    version = getattr(xarm_emu, "__version__", None)
    if isinstance(version, str):
        return version
    from importlib.metadata import version as dist_version

    return dist_version("xarm-emu")


def pages(root: Path | None = None) -> list[Page]:
    """Every generated page, in navigation order: the reference, then, given the repository's root,
    the home page (from README.md) and one tutorial per numbered example of ``examples/``."""
    out: list[Page] = [("reference/index.md", "Overview", _index())]
    out += registers.pages()
    out += [tables.codes_page(), tables.modbus_page(), tables.devices_page(), tables.files_page(),
            cli.page()]
    if root is not None:
        out += [tutorials.home(root / "README.md"), *tutorials.pages(root / "examples")]
    return out


def _index() -> str:
    return "\n".join([
        "# Reference",
        "",
        f"Generated from the tables of xarm-emu {package_version()} when this site was built: what the "
        "emulator answers is what these pages say, as both read the same tables.",
        "",
        "- [Registers](registers/index.md): every command-port register of every firmware profile, "
        "with its request and reply layout, flags and the version it appears in.",
        "- [Error and warning codes](codes.md): control box errors, warnings, servo and gripper codes "
        "with their handling.",
        "- [Standard Modbus-TCP map](modbus.md): coils, discrete inputs, holding and input registers.",
        "- [Device registers](devices.md): the Modbus-RTU registers of each device on the RS-485 buses.",
        "- [File keys](files.md): the keys of scene, fault, fleet, calibration and tolerance files.",
        "- [Command line](cli.md): every `xarm-emu` command and option.",
        "",
    ])
