"""Atomic file writes: a crash, a full disk or a kill leaves the old file or the new one intact.

The text goes to a temporary file in the destination's folder (same file system), is flushed and
synced to disk, and then renamed over the destination (``os.replace``, atomic on POSIX and
Windows); the folder is synced too, so the rename itself survives a power cut. Keyframe files and
calibration files are written this way.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from pathlib import Path

from armctl.errors import ConfigError, KeyPath

__all__ = ["write_atomic"]

#: Permissions of a new file (an existing file keeps its own).
_NEW_FILE_MODE = 0o644


def write_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename.

    An existing file keeps its permissions; a new one gets ``rw-r--r--``. If anything fails,
    the temporary file is removed and ``path`` is left as it was.

    Args:
        path: The destination file.
        text: Its new content (written as UTF-8).

    Returns:
        The path written.

    Raises:
        ConfigError: If the file cannot be written (missing or read-only folder, disk full);
            the previous file is intact.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        mode = stat.S_IMODE(path.stat().st_mode) if path.exists() else _NEW_FILE_MODE
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())
            os.chmod(tmp, mode)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        _sync_folder(folder)
    except OSError as exc:
        raise ConfigError(f"cannot write the file: {exc}; the previous file (if any) is "
                          "unchanged", KeyPath(path),
                          "check that the folder exists, is writable and has free space") from exc
    return path


def _sync_folder(folder: Path) -> None:
    """Sync a folder's entries to disk (where the OS allows opening a folder)."""
    try:
        dfd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        with contextlib.suppress(OSError):
            os.fsync(dfd)
    finally:
        os.close(dfd)
