"""One reader of the project's TOML files (calibrations, tolerances): the whole file or one line
that says why not, raised as the caller's own error type."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any


def read_toml(path: Path | str, error: type[Exception]) -> dict[str, Any]:
    """The table of the TOML file at ``path``; ``error`` with a one-line reason when it cannot be
    read or is not TOML."""
    try:
        return tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise error(f"cannot read {path}: {exc.strerror or exc}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise error(f"{path} is not TOML: {exc}") from None
