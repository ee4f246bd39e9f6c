"""Run every ``benchmarks/bench_*.py`` in one process and print one combined table.

Each script's ``measure() -> list[Row]`` is called in turn (scripts sorted by
name); every row holds our figure and the peer's, measured in this run.

Usage::

    python benchmarks/run_all.py [--only rls,plant]
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

from _table import Row, print_rows  # noqa: E402


def bench_modules() -> list[str]:
    """Module names of every ``bench_*.py`` beside this file, sorted."""
    return sorted(p.stem for p in HERE.glob("bench_*.py"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--only",
        default="",
        help="comma-separated subset, e.g. 'rls,plant' for bench_rls.py and bench_plant.py",
    )
    args = parser.parse_args(argv)
    names = bench_modules()
    if args.only:
        wanted = {
            f"bench_{n.strip().removeprefix('bench_').removesuffix('.py')}" for n in args.only.split(",")
        }
        unknown = wanted - set(names)
        if unknown:
            parser.error(f"--only: no such benchmark {sorted(unknown)}; have {names}")
        names = [n for n in names if n in wanted]

    rows: list[Row] = []
    failed: list[str] = []
    for name in names:
        print(f"running {name} ...", file=sys.stderr, flush=True)
        start = time.perf_counter()
        try:
            module = importlib.import_module(name)
            rows.extend(module.measure())
        except Exception as exc:  # report and go on: one broken peer must not hide the others
            failed.append(name)
            print(f"{name} failed: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
        print(f"  {name}: {time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)

    print_rows(rows, f"motorid benchmarks against peers ({', '.join(names)})")
    if failed:
        print(f"\nFAILED: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
