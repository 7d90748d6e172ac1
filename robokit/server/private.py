"""Files and folders only the server's own user may read: the data folder, the database, uploads.

Modes are set at creation and then by ``chmod``, so the result does not depend on the process's umask (a umask
of 022 would otherwise leave a new SQLite database and upload folders readable by every user of the machine). The
data folder and the SQLite files that earlier versions left readable by others are narrowed when the server starts.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

DIR_MODE, FILE_MODE = 0o700, 0o600


def private_dir(path: Path) -> None:
    """Create ``path`` and every missing parent as 0700; folders that already exist are left as they are."""
    missing = []
    here = path
    while not here.exists():
        missing.append(here)
        here = here.parent
    for folder in reversed(missing):
        try:
            folder.mkdir(mode=DIR_MODE)
        except FileExistsError:  # made by a concurrent upload: that request sets its mode
            continue
        os.chmod(folder, DIR_MODE)


def private_file(path: Path) -> None:
    """Create ``path`` empty as 0600 when it does not exist yet (e.g. the SQLite database, before SQLite opens it:
    SQLite then gives its -wal and -shm files the database's mode)."""
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, FILE_MODE)
    except FileExistsError:
        return
    os.close(fd)
    os.chmod(path, FILE_MODE)


def private_sqlite(database: dict[str, Any]) -> list[Path]:
    """For Django's ``DATABASES["default"]``: when it is a SQLite file, create it (and its folder) private now, and
    make an existing one (with its ``-wal`` and ``-shm`` files) private if others could read it, as versions before
    this one left it. Returns the files whose mode was narrowed."""
    name = str(database.get("NAME") or "")
    if not database.get("ENGINE", "").endswith("sqlite3") or not name or name == ":memory:" or name.startswith("file:"):
        return []
    path = Path(name)
    private_dir(path.parent)
    private_file(path)
    return [p for p in (path, Path(f"{name}-wal"), Path(f"{name}-shm")) if narrow(p, FILE_MODE)]


def narrow(path: Path, mode: int) -> bool:
    """Take away group and other access from an existing ``path`` (to ``mode``); True when its mode changed."""
    try:
        current = path.stat().st_mode & 0o777
    except FileNotFoundError:
        return False
    if current & 0o077 == 0:
        return False
    os.chmod(path, mode)
    return True
