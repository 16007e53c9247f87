"""Saved configuration of the control box: one JSON file per robot serial number.

Register 40 (0x28, "Save the current system configuration parameters") writes the current settings through
:meth:`ConfigStore.save`; register 39 (0x27, "Delete the current system configuration parameters") removes
them with :meth:`ConfigStore.delete`; at start the controller restores them with :meth:`ConfigStore.load`.
The store does not interpret the values: any dict of JSON values (tuples come back as lists).

Crash safety: a save writes a temporary file in the same directory, flushes and fsyncs it, renames it over
the target with ``os.replace`` (atomic on POSIX and Windows) and fsyncs the directory, so after a crash
(SIGKILL, power loss) the file is either the old complete one or the new complete one. The file carries a
format name, a format version and a SHA-256 checksum of its content, so a torn or hand-edited file is
detected at load. A file that cannot be read or checked is renamed aside to
``<name>.corrupt-<UTC timestamp>`` with one message in :attr:`ConfigStore.last_error`, and ``load`` returns
``None`` (the emulator then starts with defaults).

One box per file: ``xarm-emu serve`` locks each arm's file (:meth:`ConfigStore.lock`), so a second
emulator with the same serial number and directory (e.g. two of the same model with default options)
refuses to start instead of loading and overwriting the first one's settings. On a folder that
cannot be written (a read-only mount) the box still starts and loads what is saved; saving is off
(said once in the log) and the lock is taken on the saved file opened read-only.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import logging
import os
import re
import secrets
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import Future
from pathlib import Path
from typing import IO, Any

from ...protocol.admin_token import (  # noqa: F401  (kept importable here)
    ADMIN_TOKEN_ENV,
    ADMIN_TOKEN_NAME,
    APP_DIR_NAME,
    admin_token_path,
    default_config_dir,
    read_admin_token,
)

try:
    import fcntl
except ImportError:  # Windows: no advisory locks, one emulator per directory is up to the user
    fcntl = None  # type: ignore[assignment]

log = logging.getLogger(__name__)

FORMAT_NAME = "xarm-emu-config"
FORMAT_VERSION = 1

_SAFE_SN = re.compile(r"[^A-Za-z0-9_.-]")


def load_or_create_admin_token(path: Path | None = None) -> str:
    """The admin token in ``path``, created (random, mode 0600, directory 0700) when missing; a
    token file others can read is made owner-only again with a log line."""
    path = path or admin_token_path()
    token = read_admin_token(path)
    if token is not None:
        if os.name != "nt" and path.stat().st_mode & 0o077:
            log.warning("admin token %s was readable by other users; made owner-only", path)
            os.chmod(path, 0o600)
        return token
    path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.tmp-", dir=path.parent)  # mode 0600
    try:
        with os.fdopen(fd, "w", encoding="ascii") as f:
            f.write(secrets.token_hex(16) + "\n")
        try:
            os.link(tmp, path)  # never replaces a token another server created meanwhile
        except FileExistsError:
            pass
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
    token = read_admin_token(path)
    if token is None:
        raise OSError(f"cannot read the admin token {path}")
    return token


def file_name_for(robot_sn: str) -> str:
    """File name of a serial number's configuration; characters outside [A-Za-z0-9_.-] are replaced and a
    short hash of the real SN is added then, so two serial numbers never share a file."""
    sn = str(robot_sn)
    safe = _SAFE_SN.sub("_", sn).strip(".") or "unknown"
    if safe != sn:
        safe = f"{safe}-{hashlib.sha256(sn.encode('utf-8')).hexdigest()[:8]}"
    return f"config-{safe}.json"


def _canonical(robot_sn: str, values: dict[str, Any]) -> bytes:
    body = {"format": FORMAT_NAME, "version": FORMAT_VERSION, "robot_sn": robot_sn, "values": values}
    return json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=True,
                      allow_nan=False).encode("ascii")


def _fsync_dir(directory: Path) -> None:
    if os.name == "nt":  # directories cannot be opened for fsync on Windows; os.replace is durable there
        return
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


class ConfigLocked(ValueError):
    """Another running emulator holds this saved configuration (:meth:`ConfigStore.lock`)."""


class ConfigStore:
    """The saved configuration of one robot (by serial number) in ``directory``."""

    def __init__(self, directory: Path | str, robot_sn: str) -> None:
        self.directory = Path(directory)
        self.robot_sn = str(robot_sn)
        self.path = self.directory / file_name_for(self.robot_sn)
        #: One human-readable message about the last ``load`` that found an unusable file, else ``None``.
        self.last_error: str | None = None
        #: When set, :meth:`save` and :meth:`delete` hand their disk work to this function (a disk
        #: worker's ``submit``) instead of doing it in place; the job's future is :attr:`inflight`.
        self.writer: Callable[[Callable[[], Any]], Future[Any]] | None = None
        #: The future of the last job handed to :attr:`writer` (taken by whoever waits for it).
        self.inflight: Future[Any] | None = None
        #: Why the last save or delete failed (``None`` after one that succeeded).
        self.last_save_error: str | None = None
        self._lock_file: IO[str] | None = None
        #: Why the folder cannot be written, when :meth:`lock` found it so (saving is off), else ``None``.
        self.read_only: str | None = None

    # -- one box per file (serve) ---------------------------------------------------------------------

    def lock(self) -> None:
        """Claim this configuration for this process: an exclusive lock on ``<file>.lock`` (POSIX
        ``flock``, released when the process ends). Raises :class:`ConfigLocked` when another
        running emulator holds it, so two boxes never load and save each other's settings."""
        if fcntl is None or self._lock_file is not None:
            return
        lock_path = self.path.with_name(self.path.name + ".lock")
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            f = open(lock_path, "a+")  # noqa: SIM115 - held for the life of the process
        except OSError as exc:
            if exc.errno not in _READ_ONLY:
                raise
            self._lock_read_only(exc)
            return
        try:
            fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.seek(0)
            holder = f.read().strip() or "another process"
            f.close()
            raise self._locked(f"pid {holder}") from None
        f.seek(0)
        f.truncate()
        f.write(f"{os.getpid()}\n")
        f.flush()
        self._lock_file = f

    def _locked(self, holder: str) -> ConfigLocked:
        return ConfigLocked(
            f"the saved configuration {self.path} is in use by a running emulator ({holder}); "
            f"two boxes with the same serial number must not share it: give this one its own "
            f"--config-dir (or a fleet file with distinct robot_sn)")

    def _lock_read_only(self, exc: OSError) -> None:
        """The folder cannot be written (a read-only mount, a ConfigMap): saving is off, said once in
        the log; the lock is ``flock`` on the saved file opened read-only (no write needed), or none
        when there is no saved file to open."""
        self.read_only = describe_os_error(exc)
        log.warning("configuration folder %s cannot be written (%s): saving is off, save_conf and "
                    "clean_conf answer as a box that cannot save", self.directory, self.read_only)
        try:
            f = open(self.path)  # noqa: SIM115 - held for the life of the process
        except OSError:
            log.info("no saved configuration %s to lock; two servers on this folder are not kept "
                     "apart (neither can save)", self.path)
            return
        try:
            fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.close()
            raise self._locked("read-only folder") from None
        self._lock_file = f

    def unlock(self) -> None:
        f, self._lock_file = self._lock_file, None
        if f is not None:
            f.close()

    # -- reading ---------------------------------------------------------------------------------------

    def load(self) -> dict[str, Any] | None:
        """Saved values, or ``None`` when nothing is saved or the file is unusable (see ``last_error``)."""
        self.last_error = None
        self._remove_stale_temps()
        try:
            raw = self.path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as exc:
            self._set_aside(f"cannot read it ({exc.strerror or exc})")
            return None
        try:
            return self._decode(raw)
        except ValueError as exc:
            self._set_aside(str(exc))
            return None

    def _decode(self, raw: bytes) -> dict[str, Any]:
        try:
            doc = json.loads(raw.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ValueError(f"not valid JSON ({exc})") from None
        if not isinstance(doc, dict) or doc.get("format") != FORMAT_NAME:
            raise ValueError("not an xarm-emu configuration file")
        if doc.get("version") != FORMAT_VERSION:
            raise ValueError(f"format version {doc.get('version')!r} is not supported "
                             f"(expected {FORMAT_VERSION})")
        values = doc.get("values")
        if not isinstance(values, dict):
            raise ValueError("no values in the file")
        if doc.get("robot_sn") != self.robot_sn:
            raise ValueError(f"it belongs to serial number {doc.get('robot_sn')!r}, not {self.robot_sn!r}")
        try:
            digest = hashlib.sha256(_canonical(self.robot_sn, values)).hexdigest()
        except ValueError as exc:
            raise ValueError(f"values cannot be checked ({exc})") from None
        if doc.get("sha256") != digest:
            raise ValueError("checksum mismatch (torn or edited file)")
        return values

    def _set_aside(self, reason: str) -> None:
        stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
        aside = self.path.with_name(f"{self.path.name}.corrupt-{stamp}")
        n = 1
        while aside.exists():
            aside = self.path.with_name(f"{self.path.name}.corrupt-{stamp}-{n}")
            n += 1
        try:
            os.replace(self.path, aside)
            with contextlib.suppress(OSError):
                _fsync_dir(self.directory)
            where = f"moved it to {aside}"
        except OSError as exc:
            where = f"could not move it aside ({exc.strerror or exc})"
        self.last_error = (f"saved configuration {self.path} is unusable: {reason}; {where}; "
                           f"starting with default settings")
        log.warning("%s", self.last_error)

    def _temp_prefix(self) -> str:
        return f".{self.path.name}.tmp-"

    def _remove_stale_temps(self) -> None:
        """Delete temporary files left by a writer that died mid-save (its pid is in the name)."""
        prefix = self._temp_prefix()
        try:
            entries = list(self.directory.iterdir())
        except OSError:
            return
        for entry in entries:
            if not entry.name.startswith(prefix):
                continue
            pid_text = entry.name[len(prefix):].split("-", 1)[0]
            if pid_text.isdigit() and _pid_alive(int(pid_text)):
                continue
            with contextlib.suppress(OSError):
                entry.unlink()

    # -- writing ---------------------------------------------------------------------------------------

    def save(self, values: dict[str, Any]) -> None:
        """Write ``values`` atomically. Raises ``TypeError``/``ValueError`` for values JSON cannot hold
        exactly (e.g. NaN) and ``OSError`` when the directory is not writable; the old file then stays.
        With a :attr:`writer` the write runs there and its outcome is in :attr:`inflight`."""
        data = self.encode(values)
        if self.writer is None:
            self.write_encoded(data)
        else:
            self.inflight = self.writer(lambda: self.write_encoded(data))

    def encode(self, values: dict[str, Any]) -> bytes:
        """The file's bytes for ``values`` (format name, version, checksum)."""
        if not isinstance(values, dict):
            raise TypeError("configuration values must be a dict")
        body = _canonical(self.robot_sn, values)
        doc = {
            "format": FORMAT_NAME,
            "version": FORMAT_VERSION,
            "robot_sn": self.robot_sn,
            "saved_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "sha256": hashlib.sha256(body).hexdigest(),
            "values": values,
        }
        return json.dumps(doc, indent=1, sort_keys=True, allow_nan=False).encode("utf-8") + b"\n"

    def write_encoded(self, data: bytes) -> None:
        """Replace the file with ``data``: temporary file, fsync, rename, fsync of the directory."""
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f"{self._temp_prefix()}{os.getpid()}-", dir=self.directory)
            try:
                with os.fdopen(fd, "wb") as f:
                    f.write(data)
                    f.flush()
                    os.fsync(f.fileno())
                os.replace(tmp, self.path)
            except BaseException:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
                raise
            _fsync_dir(self.directory)
        except OSError as exc:
            self._save_failed("save", exc)
            raise
        self.last_save_error = None

    def _save_failed(self, what: str, exc: OSError) -> None:
        cause = describe_os_error(exc)
        first = self.last_save_error != cause
        self.last_save_error = cause
        if first:  # one line per cause, not one per failed save
            log.warning("cannot %s the configuration %s: %s; the saved file is unchanged",
                        what, self.path, cause)

    def delete(self) -> bool:
        """Remove the saved configuration; ``True`` if there was one (with a :attr:`writer`, the
        removal runs there and ``True`` means it was asked for)."""
        if self.writer is not None:
            self.inflight = self.writer(self._delete)
            return True
        return self._delete()

    def _delete(self) -> bool:
        try:
            self.path.unlink()
        except FileNotFoundError:
            return False
        except OSError as exc:
            self._save_failed("delete", exc)
            raise
        _fsync_dir(self.directory)
        return True


#: Errors that mean the configuration folder cannot be written at all.
_READ_ONLY = frozenset({errno.EROFS, errno.EACCES, errno.EPERM})

_CAUSES = {
    errno.ENOSPC: "disk full",
    errno.EDQUOT: "disk quota exceeded",
    errno.EROFS: "read-only file system",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied",
    errno.EIO: "input/output error",
    errno.ENOENT: "directory missing",
}


def describe_os_error(exc: BaseException) -> str:
    """A short cause for a failed write: "disk full (ENOSPC)", "read-only file system (EROFS)", ..."""
    if isinstance(exc, OSError) and exc.errno is not None:
        name = errno.errorcode.get(exc.errno, str(exc.errno))
        cause = _CAUSES.get(exc.errno, exc.strerror or str(exc))
        where = f": {exc.filename}" if exc.filename else ""
        return f"{cause} ({name}){where}"
    return str(exc) or type(exc).__name__
