"""What motorid reads whole from a small file (a register map, a reference): one check before the read.

:func:`read_small_file` opens the file without waiting on it (``O_NONBLOCK``: a FIFO
no one writes does not hang the command), refuses anything but a regular file (a
FIFO, a device such as ``/dev/zero``, a folder) and a file larger than its bound,
and reads at most that bound (a file that grows while it is read is refused too),
so no input can hold a command or fill its memory. Each refusal is one
:class:`~motorid.errors.DataError` naming the file and what is wrong.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from motorid.errors import DataError

__all__ = ["read_small_file"]


def read_small_file(path: str | os.PathLike[str], what: str, max_bytes: int) -> bytes:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them.

    Parameters
    ----------
    path : path-like
        The file.
    what : str
        What the file is, at the front of a refusal (``--map``, ``register map``).
    max_bytes : int
        The largest file accepted [bytes].

    Returns
    -------
    bytes
        The whole file.

    Raises
    ------
    DataError
        ``"{what} {path}: ..."``: the file is missing or unreadable, is not a regular file
        (a FIFO, a device, a folder), or is larger than ``max_bytes``.
    """
    path = Path(path)
    where = f"{what} {path}"
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY)
    except OSError as exc:
        raise DataError(f"{where}: cannot read it: {exc.strerror or exc}") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = (
                "a folder"
                if stat.S_ISDIR(mode)
                else "a FIFO"
                if stat.S_ISFIFO(mode)
                else "a device or socket"
            )
            raise DataError(f"{where}: is {kind}, not a regular file")
        size = os.fstat(fd).st_size
        if size > max_bytes:
            raise DataError(f"{where}: is {size:,} bytes, more than the {max_bytes:,} accepted")
        chunks = []
        got = 0
        while got <= max_bytes:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - got))
            if not chunk:
                break
            chunks.append(chunk)
            got += len(chunk)
        if got > max_bytes:
            raise DataError(f"{where}: grew past the {max_bytes:,} bytes accepted while it was read")
        return b"".join(chunks)
    except OSError as exc:
        raise DataError(f"{where}: cannot read it: {exc.strerror or exc}") from None
    finally:
        os.close(fd)
