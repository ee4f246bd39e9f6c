"""False-alarm rate of the workflow on records with no hidden effect.

A no-effect record is a random rig (:func:`motorid.diagnose.synthetic.planted_record`
with no effect: viscous and Coulomb friction, both in the base model, plus the
rig's own sensor noise, A/D quantisation, electrical lag and a stiff but not
rigid shaft). Whatever the workflow names there is a false alarm.

Run ``python -m motorid.diagnose.calibration --seeds 100`` to measure the rate
at the default threshold and print the quantiles of the best candidate's
ΔBIC (what the threshold is calibrated against).

Measured with ``--seeds 200 --first 5000`` (30 s records at 100 Hz): nothing
named on 0 of 200 records, a false-alarm rate of 0 % (below 1.5 % with 95 %
confidence); the best candidate's ΔBIC had median -5.5 and 99th percentile
6.7, under the threshold of 10 before the held-out and free-run checks.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass

import numpy as np

from motorid.diagnose.synthetic import planted_record
from motorid.diagnose.workflow import DEFAULT_THRESHOLD, diagnose


@dataclass
class FalseAlarms:
    """Outcome over ``seeds`` no-effect records."""

    seeds: list[int]
    named: list[list[str]]
    best_delta_bic: list[float]

    @property
    def rate(self) -> float:
        """Share of records on which something was named."""
        return float(np.mean([bool(n) for n in self.named])) if self.named else float("nan")


def false_alarms(seeds: range | list[int], threshold: float = DEFAULT_THRESHOLD, **kwargs) -> FalseAlarms:
    """Run the workflow on no-effect records; ``kwargs`` go to :func:`planted_record`."""
    named, best = [], []
    seeds = list(seeds)
    for seed in seeds:
        p = planted_record(None, seed, **kwargs)
        d = diagnose(p.record, input_gain=p.input_gain, base=p.base, max_steps=1, threshold=threshold)
        named.append(d.named)
        ranking = d.steps[0].evidence["ranking"] if d.steps else None
        if ranking is None:
            text = d.stop_reason
            best.append(float(text.split("ΔBIC = ")[1].split(" ")[0]) if "ΔBIC = " in text else float("nan"))
        else:
            best.append(float(ranking[0]["delta_bic"]))
    return FalseAlarms(seeds, named, best)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100, help="number of records (seeds 0..N-1)")
    parser.add_argument("--first", type=int, default=1000, help="first seed (default 1000)")
    parser.add_argument("--threshold", type=float, default=DEFAULT_THRESHOLD)
    args = parser.parse_args(argv)
    fa = false_alarms(range(args.first, args.first + args.seeds), threshold=args.threshold)
    q = np.nanquantile(fa.best_delta_bic, [0.5, 0.9, 0.95, 0.99])
    sys.stdout.write(
        f"no-effect records: {len(fa.seeds)}, named something on {sum(bool(n) for n in fa.named)} "
        f"-> false-alarm rate {100 * fa.rate:.1f} % at threshold {args.threshold:g}\n"
        f"best candidate's ΔBIC: median {q[0]:.1f}, 90 % {q[1]:.1f}, 95 % {q[2]:.1f}, 99 % {q[3]:.1f}\n"
    )
    for seed, n, b in zip(fa.seeds, fa.named, fa.best_delta_bic, strict=True):
        if n:
            sys.stdout.write(f"  seed {seed}: named {n} (ΔBIC {b:.1f})\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
