"""NI TDMS records (npTDMS): a column per channel, named ``group/channel`` (or by the channel's
name alone when it is unique); a waveform's ``wf_increment`` gives the sample time.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from motorid.errors import DataError
from motorid.io.records.columns import Choose
from motorid.io.records.files import ATTRS_KEY, attrs_from_json, one_line_reason

logger = logging.getLogger(__name__)


class _Collected(logging.Handler):
    """The distinct messages a library logs while a file is read (to be said once, with the file's name)."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        text = text if len(text) <= 200 else text[:200] + " ..."
        if text not in self.messages:
            self.messages.append(text)


def read_tdms(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Columns ``group/channel``; ``dt`` from the channels' ``wf_increment`` when the file has no attrs' dt.

    npTDMS's own warnings (printed by its handler and again through the root logger) are
    collected while the file is read and logged once each, naming the file, when it is read.
    """
    from nptdms import TdmsFile
    from nptdms.log import log_manager

    collected = _Collected()
    loggers = [(log, log.propagate, list(log.handlers)) for log in log_manager.loggers.values()]
    for log, _, _ in loggers:
        log.propagate, log.handlers = False, [collected]
    try:
        columns = _tdms_columns(name, choose, TdmsFile)
    finally:
        for log, propagate, handlers in loggers:
            log.propagate, log.handlers = propagate, handlers
    for message in collected.messages:  # a refused file says only why it is refused
        logger.warning("%s: %s", name, message)
    return columns


def _tdms_columns(name: str, choose: Choose, tdms_file: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    try:
        tdms = tdms_file.open(name)
    except Exception as exc:  # npTDMS raises ValueError, KeyError, struct errors ... on a foreign file
        raise DataError(f"{name} is not a readable TDMS file: {one_line_reason(exc)}") from None
    with tdms:
        channels = {f"{g.name}/{c.name}": c for g in tdms.groups() for c in g.channels()}
        if not channels:  # a header and then bytes that hold no channel
            raise DataError(f"{name} is not a readable TDMS file: it holds no channel")
        attrs = attrs_from_json(tdms.properties.get(ATTRS_KEY), name, f"the file property {ATTRS_KEY!r}")
        chosen = choose({key: (len(channel),) for key, channel in channels.items()})
        increments = {channels[key].properties.get("wf_increment") for key in chosen}
        if "dt" not in attrs and len(increments) == 1 and None not in increments:
            attrs["dt"] = float(increments.pop())
        try:
            return {key: np.asarray(channels[key][:]) for key in chosen}, attrs
        except Exception as exc:  # a damaged data segment
            raise DataError(
                f"{name}: its TDMS data cannot be read (corrupt or cut?): {one_line_reason(exc)}"
            ) from None
