"""The one reader of the project's TOML files (fleets, fault schedules, contact scenes, calibrations,
compare tolerances), with one error format.

Every refusal is one line that names the file, and the line where TOML gives it::

    <what> <path>: <why>
    <what> <path>, line <n>, column <m>: not valid TOML: <what the TOML reader says>

for example ``fleet file fleet.toml: cannot be read: No such file or directory``, ``fleet file
fleet.toml, line 3, column 7: not valid TOML: Expected ']' at the end of a table declaration``,
``fleet file fleet.toml: arm 1: host must be an address string, got 5`` and ``fleet file fleet.toml:
arm 1: unknown key 'colour'; known: model, host, ...`` (:func:`check_keys`). It is raised as the
caller's own error type (a ``ValueError``), so the CLI answers it on one line.

Stdlib only, below every other layer: the controller, the model and the server all read with it.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, TypeVar

T = TypeVar("T")

#: Where tomllib's message says the syntax error is.
_AT = re.compile(r"\s*\(at line (\d+), column (\d+)\)$")


def _refusal(what: str, path: Path | str, why: str, line: int | None = None,
             column: int | None = None) -> str:
    where = f"{what} {path}" if what else str(path)
    if line is not None:
        where += f", line {line}" + (f", column {column}" if column is not None else "")
    return f"{where}: {why}"


def read_toml(path: Path | str, error: type[Exception], what: str = "file") -> dict[str, Any]:
    """The table of the TOML file at ``path``; ``error`` with one line (the module's format) when
    it cannot be read or is not TOML. ``what`` names the kind of file ("fleet file")."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise error(_refusal(what, path, f"cannot be read: {exc.strerror or exc}")) from None
    except UnicodeDecodeError as exc:
        raise error(_refusal(what, path, f"not valid TOML: not UTF-8 text ({exc.reason})")) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message = str(exc)
        at = _AT.search(message)
        if at is None:
            raise error(_refusal(what, path, f"not valid TOML: {message}")) from None
        raise error(_refusal(what, path, f"not valid TOML: {message[: at.start()]}",
                             int(at.group(1)), int(at.group(2)))) from None


def load_toml(path: Path | str, what: str, parse: Callable[[dict[str, Any]], T],
              error: type[Exception] = ValueError) -> T:
    """Read the TOML file at ``path`` and ``parse`` its table; every ValueError of either comes as
    ``error`` with one line in the module's format (``what`` names the kind of file)."""
    data = read_toml(path, error, what)
    try:
        return parse(data)
    except ValueError as exc:
        raise error(_refusal(what, path, str(exc))) from None


def check_keys(table: Mapping[str, Any], known: Iterable[str], where: str = "",
               error: type[Exception] = ValueError) -> None:
    """Refuse a key of ``table`` that is not ``known``: ``[where: ]unknown key 'k'; known: a, b``."""
    names = tuple(known)
    extra = sorted(set(table) - set(names))
    if extra:
        prefix = f"{where}: " if where else ""
        raise error(f"{prefix}unknown key {extra[0]!r}; known: {', '.join(names)}")
