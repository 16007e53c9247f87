"""Where the admin channel's token lives and how it is written, for server and client alike.

Every admin request carries the token (:mod:`.admin`); the server creates the file
(:func:`xarm_emu.controller.core.config.load_or_create_admin_token`, owner-only) and a client reads it, so
the rule for its place is kept here, below both. No sockets: the place is computed from the
environment, and the file holds one line of ASCII.
"""

from __future__ import annotations

import os
from pathlib import Path

APP_DIR_NAME = "xarm-emu"
#: File of the admin channel's token in the per-user configuration directory (owner-only permissions);
#: ``$XARM_EMU_ADMIN_TOKEN_FILE`` names another one for server and clients alike.
ADMIN_TOKEN_NAME = "admin-token"
ADMIN_TOKEN_ENV = "XARM_EMU_ADMIN_TOKEN_FILE"


def default_config_dir() -> Path:
    """Per-user configuration directory: ``$XDG_CONFIG_HOME/xarm-emu``, else ``~/.config/xarm-emu``
    (``%APPDATA%\\xarm-emu`` on Windows)."""
    if os.name == "nt" and os.environ.get("APPDATA"):
        return Path(os.environ["APPDATA"]) / APP_DIR_NAME
    xdg = os.environ.get("XDG_CONFIG_HOME", "")
    if xdg and os.path.isabs(xdg):
        return Path(xdg) / APP_DIR_NAME
    return Path.home() / ".config" / APP_DIR_NAME


def admin_token_path() -> Path:
    """Where the admin token is: ``$XARM_EMU_ADMIN_TOKEN_FILE``, else ``admin-token`` in
    :func:`default_config_dir`."""
    env = os.environ.get(ADMIN_TOKEN_ENV, "")
    return Path(env) if env else default_config_dir() / ADMIN_TOKEN_NAME


def read_admin_token(path: Path | None = None) -> str | None:
    """The admin token in ``path`` (default :func:`admin_token_path`), or ``None`` without one."""
    try:
        text = (path or admin_token_path()).read_text(encoding="ascii").strip()
    except (OSError, UnicodeDecodeError):
        return None
    return text or None
