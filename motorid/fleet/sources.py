"""Which records a fleet run takes, and the drive and time of each.

Records are named by glob patterns, folders (every record file in them, not
recursing) or list files (``@list.txt``: one path per line, ``#`` comments).
The drive id and the record time come from a file-name pattern
(:class:`FilenamePattern`) when one is given, else from the record's attrs
(``attrs["drive"]``, ``attrs["time"]``, see :mod:`motorid.io.records`), else the
drive is the file's stem and the time unknown.
"""

from __future__ import annotations

import glob
import logging
import os
import re
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

from motorid.errors import DataError
from motorid.io.records import DRIVE_ATTR, RECORD_FORMATS, TIME_ATTR

logger = logging.getLogger(__name__)

#: Extensions of the files a folder contributes (CSV and the formats read_record knows).
RECORD_EXTENSIONS = (".csv", *RECORD_FORMATS)


def find_records(items: list[str]) -> list[Path]:
    """The record files named by ``items`` (globs, folders, ``@list`` files, files), sorted, each once.

    Parameters
    ----------
    items : list of str
        Each a record file, a glob (``logs/*.csv``), a folder (its files of the known record
        formats, :data:`RECORD_EXTENSIONS`) or ``@list.txt`` (one path a line, relative to the
        list file; ``#`` starts a comment).

    Raises
    ------
    DataError
        Naming an item that matches nothing (a glob with no match, a missing file or list file,
        a folder with no record file), or when there is no record at all.
    """
    found: dict[str, Path] = {}
    for item in items:
        if item.startswith("@"):
            listing = Path(item[1:])
            if not listing.is_file():
                raise DataError(f"list file {listing}: no such file")
            base = listing.parent
            names = [
                line.split("#", 1)[0].strip() for line in listing.read_text(encoding="utf-8").splitlines()
            ]
            paths = [base / name if not os.path.isabs(name) else Path(name) for name in names if name]
        elif os.path.isdir(item):
            paths = sorted(
                p for p in Path(item).iterdir() if p.suffix.lower() in RECORD_EXTENSIONS and p.is_file()
            )
            if not paths:
                raise DataError(f"folder {item} holds no record file ({', '.join(RECORD_EXTENSIONS)})")
        elif glob.has_magic(item):
            paths = [Path(p) for p in sorted(glob.glob(item)) if os.path.isfile(p)]
            if not paths:
                raise DataError(f"{item!r} matches no file")
        else:
            paths = [Path(item)]  # a missing one becomes a failed row naming it, as any bad file does
        for path in paths:
            found.setdefault(os.path.abspath(path), path)
    if not found:
        raise DataError("no record given")
    return sorted(found.values(), key=lambda p: os.path.abspath(p))


@dataclass(frozen=True)
class FilenamePattern:
    """The drive id and time in a record's file name, e.g. ``{drive}_{date:%Y%m%d}.csv``.

    Fields: ``{drive}`` (any text without ``/``), and the time as ``{date:FORMAT}`` or
    ``{time:FORMAT}`` with a :func:`datetime.strptime` format. Any other ``{name}`` matches
    text that is ignored. Everything else in the pattern is literal. The pattern matches the
    end of the path: as many of its last parts as the pattern has (``{drive}/{date:%Y%m%d}.csv``
    takes the drive from the folder).

    Attributes
    ----------
    pattern : str
        The pattern, e.g. ``"{drive}_{date:%Y%m%d}.csv"`` (``motorid fleet --pattern``).
    """

    pattern: str

    def _compiled(self) -> tuple[re.Pattern[str], dict[str, str]]:
        formats: dict[str, str] = {}
        seen: set[str] = set()
        parts, position = [], 0
        for match in re.finditer(r"\{(\w+)(?::([^}]*))?\}", self.pattern):
            parts.append(re.escape(self.pattern[position : match.start()]))
            name, fmt = match.group(1), match.group(2)
            if name in seen and name in ("drive", "date", "time"):
                raise DataError(f"pattern={self.pattern!r}: the field {{{name}}} appears twice")
            if name in ("date", "time"):
                if not fmt:
                    raise DataError(
                        f"pattern={self.pattern!r}: {{{name}}} needs a format, e.g. {{{name}:%Y%m%d}}"
                    )
                formats[name] = fmt
                parts.append(f"(?P<{name}>.+?)")
            elif name == "drive":
                parts.append("(?P<drive>[^/]+?)")
            else:
                parts.append("[^/]*?")
            seen.add(name)
            position = match.end()
        parts.append(re.escape(self.pattern[position:]))
        if "drive" not in seen and not formats:
            raise DataError(f"pattern={self.pattern!r} has neither {{drive}} nor {{date:...}}/{{time:...}}")
        return re.compile("".join(parts) + r"\Z"), formats

    def parse(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """``{"drive": str, "time": datetime}`` (those the pattern has) for ``path``.

        Raises
        ------
        DataError
            When the path's end does not match, or the time does not parse, naming both.
        """
        regex, formats = self._compiled()
        depth = self.pattern.count("/") + 1
        tail = "/".join(Path(path).parts[-depth:])
        match = regex.fullmatch(tail)
        if match is None:
            raise DataError(f"pattern={self.pattern!r} does not match the record {tail!r}")
        out: dict[str, Any] = {}
        if match.groupdict().get("drive") is not None:
            out["drive"] = match.group("drive")
        for name, fmt in formats.items():
            try:
                out["time"] = datetime.strptime(match.group(name), fmt)
            except ValueError as exc:
                raise DataError(f"pattern={self.pattern!r}: {{{name}}} of {tail!r}: {exc}") from None
        return out


def identity(
    path: str | os.PathLike[str], attrs: dict[str, Any], given: dict[str, Any]
) -> tuple[str, str | None]:
    """The record's drive id and its time as ISO 8601 text (None when unknown).

    ``given`` (from a :class:`FilenamePattern`) comes first, then ``attrs``, then the file stem for
    the drive.

    Parameters
    ----------
    path : str or PathLike
        The record file (its stem is the drive id when nothing else names one).
    attrs : dict
        The record's attributes (``attrs["drive"]``, ``attrs["time"]`` in ISO 8601).
    given : dict
        What the file name says (:meth:`FilenamePattern.parse`): ``drive`` and ``time``.

    Raises
    ------
    DataError
        When ``attrs["time"]`` is text that is not an ISO 8601 time.
    """
    drive = given.get("drive", attrs.get(DRIVE_ATTR))
    when = given.get("time", attrs.get(TIME_ATTR))
    if isinstance(when, str):
        try:
            when = datetime.fromisoformat(when)
        except ValueError:
            raise DataError(f"{path}: attrs[{TIME_ATTR!r}] = {when!r} is not an ISO 8601 time") from None
    return (str(drive) if drive is not None else Path(path).stem), (when.isoformat() if when else None)


__all__ = ["RECORD_EXTENSIONS", "FilenamePattern", "find_records", "identity"]
