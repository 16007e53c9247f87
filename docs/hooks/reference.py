"""MkDocs hook: the generated pages (xarm_emu.docsite) join the site at build time.

The reference pages come from the code's tables and the tutorials from examples/, so neither is a file
in docs/; this hook adds them to the site's files and their sections to the navigation, names the
site with the package's version, and lists any page of docs/ the navigation does not name under
"More", so a page added to docs/ is never unreachable.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.structure.files import File, Files

from xarm_emu import docsite

ROOT = Path(__file__).resolve().parents[2]
_pages: list[docsite.Page] = []


def on_config(config: MkDocsConfig) -> MkDocsConfig:
    _pages[:] = docsite.pages(ROOT)
    config.site_name = f"xarm-emu {docsite.package_version()}"
    nav: list[Any] = list(config.nav or [])
    tutorials = [{title: path} for path, title, _ in _pages if path.startswith("tutorials/")]
    reference: list[Any] = []
    registers: list[Any] = []
    for path, title, _ in _pages:
        if path.startswith("reference/registers/"):
            if not registers:
                reference.append({"Registers": registers})
            registers.append({"Overview" if path.endswith("index.md") else title: path})
        elif path.startswith("reference/"):
            reference.append({title: path})
    nav.insert(1, {"Tutorials": tutorials})
    nav.append({"Reference": reference})
    named = set(_paths(nav))
    docs = Path(config.docs_dir)
    extra = sorted(p.relative_to(docs).as_posix() for p in docs.rglob("*.md")
                   if p.relative_to(docs).parts[0] != "hooks")
    more = [p for p in extra if p not in named]
    if more:
        nav.append({"More": more})
    config.nav = nav
    return config


def _paths(nav: Any) -> list[str]:
    if isinstance(nav, str):
        return [nav]
    if isinstance(nav, dict):
        return [p for v in nav.values() for p in _paths(v)]
    return [p for item in nav for p in _paths(item)]


def on_files(files: Files, config: MkDocsConfig) -> Files:
    for path, _, text in _pages:
        files.append(File.generated(config, path, content=text))
    return files
