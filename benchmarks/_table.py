"""The one table format every ``benchmarks/bench_*.py`` reports in.

Each benchmark script defines ``measure() -> list[Row]`` and, when run on its
own, prints its rows with :func:`print_rows`. ``benchmarks/run_all.py`` calls
every ``measure()`` in one process and prints one combined table.

A row is one figure measured for motorid (``ours``) and, where a peer does the
same work, for the peer (``peer``) in the same run. ``ratio`` is the speed-up
(or quality gain) of ours over the peer, so a ratio above 1 always favours
motorid, whichever way the unit points.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

__all__ = ["Row", "Timing", "best_of", "best_times", "format_rows", "print_rows"]


@dataclass(frozen=True)
class Row:
    """One measured figure, ours beside the peer's.

    Parameters
    ----------
    figure : str
        What is measured, e.g. ``"batch RLS, p = 19"``.
    ours : float
        motorid's value, in ``unit``.
    peer : float or None
        The peer's value in the same unit, measured in the same run; None
        where no peer does the same work.
    unit : str
        Unit of ``ours`` and ``peer``, e.g. ``"samples/s"``, ``"us"``, ``"rad²/s²"``.
    peer_name : str
        Who the peer is (``"filterpy KalmanFilter"``); ``""`` without a peer.
    higher_is_better : bool
        True for rates (samples/s), False for times and errors.
    """

    figure: str
    ours: float
    peer: float | None
    unit: str
    peer_name: str
    higher_is_better: bool

    @property
    def ratio(self) -> float | None:
        """Advantage of ours over the peer (> 1 favours ours); None without a peer.

        ``ours / peer`` when higher is better, ``peer / ours`` otherwise.
        """
        if self.peer is None:
            return None
        num, den = (self.ours, self.peer) if self.higher_is_better else (self.peer, self.ours)
        if den == 0:
            return math.inf if num > 0 else math.nan
        return num / den


def _number(value: float | None) -> str:
    """A figure with about four significant digits, thousands separated."""
    if value is None:
        return "–"
    if not math.isfinite(value):
        return str(value)
    magnitude = abs(value)
    if magnitude == 0:
        return "0"
    if magnitude >= 1000:
        return f"{value:,.0f}"
    if magnitude >= 1e-3:
        digits = max(0, 3 - math.floor(math.log10(magnitude)))
        return f"{value:.{digits}f}"
    return f"{value:.3e}"


def _ratio(value: float | None) -> str:
    if value is None:
        return "–"
    if not math.isfinite(value):
        return str(value)
    return f"{value:.3g}x" if value < 100 else f"{value:,.0f}x"


def format_rows(rows: Sequence[Row], title: str) -> str:
    """An aligned markdown table of ``rows`` under a ``### title`` line."""
    header = ["figure", "motorid", "peer", "unit", "peer name", "ours vs peer"]
    body = [
        [
            row.figure.replace("|", "\\|"),  # a bare | would split the markdown cell
            _number(row.ours),
            _number(row.peer),
            row.unit + (" ↑" if row.higher_is_better else " ↓"),
            row.peer_name or "–",
            _ratio(row.ratio),
        ]
        for row in rows
    ]
    right = [False, True, True, False, False, True]
    widths = [max(len(r[i]) for r in [header, *body]) for i in range(len(header))]

    def line(cells: list[str]) -> str:
        padded = [c.rjust(w) if r else c.ljust(w) for c, w, r in zip(cells, widths, right, strict=True)]
        return "| " + " | ".join(padded) + " |"

    rule = (
        "|"
        + "|".join(
            ("-" * (w + 1) + ":") if r else ("-" * (w + 2)) for w, r in zip(widths, right, strict=True)
        )
        + "|"
    )
    lines = [f"### {title}", "", line(header), rule, *(line(r) for r in body)]
    lines.append("")
    lines.append("↑ higher is better, ↓ lower is better; 'ours vs peer' > 1 favours motorid.")
    return "\n".join(lines)


def print_rows(rows: list[Row], title: str) -> None:
    """Print ``rows`` as an aligned markdown table under ``title``."""
    print(format_rows(rows, title), flush=True)


@dataclass(frozen=True)
class Timing:
    """The best of several runs of one piece of work.

    Parameters
    ----------
    wall : float
        Smallest wall time [s].
    cpu : float
        Smallest CPU time of this process, all its threads [s]. On a machine shared
        with other work it is the steadier figure: time spent waiting for a core
        is not counted.
    """

    wall: float
    cpu: float


def best_times(repeats: int, func: Callable[[], object]) -> Timing:
    """Smallest wall time and smallest CPU time of ``repeats`` runs of ``func``."""
    walls, cpus = [], []
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        func()
        cpus.append(time.process_time() - cpu)
        walls.append(time.perf_counter() - wall)
    return Timing(min(walls), min(cpus))


def best_of(repeats: int, func: Callable[[], object]) -> float:
    """Smallest wall time of ``repeats`` runs [s] (the least disturbed by other load)."""
    return best_times(repeats, func).wall
