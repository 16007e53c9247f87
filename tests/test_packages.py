"""Each package says what it offers: its ``__all__`` names exactly its public modules (those not
starting with an underscore), so the docstring beside it cannot silently miss a new one."""

from __future__ import annotations

import importlib
import pkgutil

import pytest

PACKAGES = ["xarm_emu.protocol", "xarm_emu.model", "xarm_emu.controller", "xarm_emu.server",
            "xarm_emu.viewer"]


@pytest.mark.parametrize("name", PACKAGES)
def test_all_lists_every_public_module(name: str) -> None:
    package = importlib.import_module(name)
    modules = {m.name for m in pkgutil.iter_modules(package.__path__) if not m.name.startswith("_")}
    assert set(package.__all__) == modules
    for module in modules:
        assert f":mod:`.{module}`" in (package.__doc__ or "") or f"``{module}``" in (package.__doc__ or "")
