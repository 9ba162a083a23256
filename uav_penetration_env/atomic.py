"""Files written whole or not at all: a temporary file in the same folder, then a rename.

Every output the project writes (leaderboards, figures, exports, scenario files, build caches,
model artefacts and their sidecars, benchmark records) goes through :func:`atomic_path` or one
of its two shorthands, so a failure or an interruption mid-write leaves the previous file, or no
file, never a truncated one that looks complete. ``os.replace`` within one folder is atomic on
POSIX and Windows; readers see the old bytes or the new ones.

DECISION (api.md §4.7): no ``fsync`` before the rename. The guarantee is against failures of the
writing program (an exception, Ctrl-C, ``kill -9``), which is what a benchmark run meets; a
power cut can still lose the newest file on some file systems, and paying a disk flush per
figure and per table is not worth that case here. The temporary file keeps the target's suffix
(``.leaderboard.md.k3j9.tmp.md``), so writers that choose their format by the suffix
(``savefig``, SB3's ``save``) write the same bytes as to the final name; it gets the mode a
plain ``open`` would have given (``0o666`` less the umask), not ``mkstemp``'s ``0o600``.

Only a regular file, or a path that does not exist yet, is replaced: the rename would put a
regular file in place of a device, a FIFO or a socket (``--out /dev/null`` run as root would
replace the null device), so such a target is refused with :class:`NotRegularFileError` before
anything is written.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any


class NotRegularFileError(OSError):
    """The target exists and is not a regular file (a device, a FIFO, a socket or a folder)."""


_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISSOCK, "a socket"),
)


def check_replaceable(path: str | Path) -> None:
    """Refuse ``path`` if it exists (through symbolic links) and is not a regular file.

    Raises:
        NotRegularFileError: naming ``path`` and what it is.
    """
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return
    except OSError:
        return  # unreadable metadata: the write itself will say why
    if stat.S_ISREG(mode):
        return
    kind = next((name for test, name in _KINDS if test(mode)), "not a regular file")
    raise NotRegularFileError(
        errno.EEXIST, f"it exists and is {kind}, not a regular file; expected a regular file or a new path", str(path)
    )


def _file_mode() -> int:
    """The mode ``open(path, "w")`` gives a new file: ``0o666`` less the process umask."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path``; renamed onto ``path`` if the block ends without an error.

    Args:
        path: the file to write (its folder is created if needed).

    Yields:
        The temporary path to write to (same folder, same suffix). On an exception, including
        ``KeyboardInterrupt``, it is removed and ``path`` is left as it was.

    Raises:
        NotRegularFileError: ``path`` exists and is not a regular file (nothing is written).
        OSError: the folder cannot be created or written (an error while writing the temporary
            file names ``path``).
    """
    path = Path(path)
    check_replaceable(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=f".tmp{path.suffix}")
    os.close(handle)
    temporary = Path(name)
    try:
        yield temporary
        os.chmod(temporary, _file_mode())
        os.replace(temporary, path)
    except OSError as error:
        temporary.unlink(missing_ok=True)
        if error.filename not in (None, str(temporary)):
            raise
        # A full disk fails the flush of a file that has no name in the error: name the target.
        raise type(error)(error.errno, error.strerror, str(path)) from error
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


@contextmanager
def atomic_open(path: str | Path, mode: str = "w", **kwargs: Any) -> Iterator[IO[Any]]:
    """``open(path, mode)`` through :func:`atomic_path` (``mode`` ``"w"`` or ``"wb"``).

    Raises:
        ValueError: ``mode`` appends or reads (an atomic file is written from the start).
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode: got {mode!r}, expected 'w' or 'wb'")
    with atomic_path(path) as temporary, open(temporary, mode, **kwargs) as stream:
        yield stream


def write_text_atomic(path: str | Path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` whole or not at all; returns ``path``."""
    with atomic_open(path, "w", encoding=encoding, newline="") as stream:
        stream.write(text)
    return Path(path)


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` whole or not at all; returns ``path``."""
    with atomic_open(path, "wb") as stream:
        stream.write(data)
    return Path(path)
