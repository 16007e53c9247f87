"""The server's log, bounded: identical lines repeated within a window are held back and counted
(:class:`RepeatFilter`), and ``serve --log-file`` writes a size-capped, rotated file
(:func:`configure`). Errors and warnings the controller raises (manual chapter 3) and client
connects and drops are logged at INFO by the server (:class:`CodeWatch`); a line that tells a
change is never held back, so every state and mode change shows, in order."""

from __future__ import annotations

import json
import logging
import logging.handlers
import time
from pathlib import Path
from typing import Any

from ..controller.core.state_machine import MODE_NAMES, STATE_NAMES
from ..protocol import codes

#: Seconds during which a line identical to one just written is held back (and counted).
REPEAT_WINDOW = 10.0
#: Distinct lines remembered for :class:`RepeatFilter` before the oldest are forgotten.
MAX_KEYS = 1024


#: ``extra`` of a record that tells a change (state, mode, error, warning): never held back, so the
#: log shows every change in order.
CHANGE = {"change": True}


class RepeatFilter(logging.Filter):
    """Drops a record identical (logger, level, message) to one passed less than ``window`` s ago;
    the next one that passes says how many were dropped meanwhile. A record that tells a change
    (``extra=CHANGE``) always passes."""

    def __init__(self, window: float = REPEAT_WINDOW) -> None:
        super().__init__()
        self.window = window
        self._seen: dict[tuple[str, int, str], tuple[float, int]] = {}

    def filter(self, record: logging.LogRecord) -> bool:
        if getattr(record, "change", False):
            return True
        try:
            text = record.getMessage()
        except Exception:  # noqa: BLE001 - a bad format string is the formatter's to report
            return True
        key = (record.name, record.levelno, text)
        now = time.monotonic()
        seen = self._seen.get(key)
        if seen is not None and now - seen[0] < self.window:
            self._seen[key] = (seen[0], seen[1] + 1)
            return False
        if len(self._seen) >= MAX_KEYS:
            self._seen.clear()
        self._seen[key] = (now, 0)
        if seen is not None and seen[1]:
            record.msg = f"{text} (repeated {seen[1]} more times in {now - seen[0]:.0f} s)"
            record.args = ()
        return True


class JsonFormatter(logging.Formatter):
    """``serve --log-json``: one JSON object a line (time, level, logger, message)."""

    def format(self, record: logging.LogRecord) -> str:
        return json.dumps({"time": record.created, "level": record.levelname, "logger": record.name,
                           "message": record.getMessage()})


def configure(level: str, log_file: Path | None = None, max_bytes: int = 0, backups: int = 3,
              json_lines: bool = False) -> None:
    """The CLI's logging: one line per record on stderr, or in ``log_file`` rotated at ``max_bytes``
    (0: never) keeping ``backups`` old files, plain or as JSON objects (``json_lines``); identical
    repeats held back (:class:`RepeatFilter`). Like :func:`logging.basicConfig`, it does nothing when
    the root logger has handlers already."""
    root = logging.getLogger()
    if root.handlers:
        return
    fmt: logging.Formatter = JsonFormatter() if json_lines else logging.Formatter(
        "%(asctime)s %(levelname)s %(name)s: %(message)s")
    handler: logging.Handler
    if log_file is not None:
        handler = logging.handlers.RotatingFileHandler(log_file, maxBytes=max(0, max_bytes),
                                                       backupCount=max(0, backups), encoding="utf-8")
    else:
        handler = logging.StreamHandler()
    handler.setFormatter(fmt)
    handler.addFilter(RepeatFilter())
    root.addHandler(handler)
    root.setLevel(level.upper())


class CodeWatch:
    """Logs each change of the motion state and mode (INFO) and of the error and warning codes with
    the manual's names (chapter 3: WARNING when raised, INFO when cleared)."""

    def __init__(self, logger: logging.Logger) -> None:
        self.logger = logger
        self._last: tuple[int, int, int, int] | None = None

    def check(self, ctl: Any) -> None:
        """Log what changed on controller ``ctl`` since the last call."""
        now = (ctl.state, ctl.mode, ctl.error_code, ctl.warning_code)
        if now == self._last:
            return
        last = self._last or (-1, -1, 0, 0)
        self._last = now
        state, mode, error, warning = now
        if state != last[0]:
            self.logger.info("state %d (%s)", state, STATE_NAMES.get(state, "?"), extra=CHANGE)
        if mode != last[1]:
            self.logger.info("mode %d (%s)", mode, MODE_NAMES.get(mode, "?"), extra=CHANGE)
        if error != last[2]:
            self.logger.log(logging.WARNING if error else logging.INFO, "error %s",
                            codes.describe_error(error) if error else "cleared", extra=CHANGE)
        if warning != last[3]:
            self.logger.log(logging.WARNING if warning else logging.INFO, "warning %s",
                            codes.describe_warning(warning) if warning else "cleared", extra=CHANGE)
