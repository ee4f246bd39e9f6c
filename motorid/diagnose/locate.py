"""Locate where a model and a measurement disagree.

The torque-balance residual r = F_in - F_model of the current model (on the
decimated samples) is binned by

- speed |w| [v], the sign of w, the sign of the acceleration a,
- input amplitude |u| [u],
- time since the last reversal of w, and since the last reversal of the
  drive force (of u) [s];

the bins of the ordered features have quantile edges, and every run of
adjacent bins is a candidate region. A region's score is the share of the
residual energy it holds minus the share of samples it holds,

    score = Σ_R r² / Σ r²  -  N_R / N,

so the winner is where the disagreement concentrates beyond its size (regions
hold between 5 % and 80 % of the samples). Inside the region the residual is
compared with sgn(w), sgn(u), sgn(a) and a constant to say which sign it
follows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.drive.input_path import time_since_reversal

MIN_FRACTION = 0.05
MAX_FRACTION = 0.8

_ORDERED = {
    "speed": ("|w|", "v"),
    "input": ("|u|", "u"),
    "time_since_reversal": ("time since the last reversal of w", "s"),
    "time_since_input_reversal": ("time since the last reversal of u", "s"),
}
_SIGNS = {"velocity_sign": "w", "acceleration_sign": "a"}


#: Every feature :func:`feature` computes.
FEATURES = (*_ORDERED, *_SIGNS, "sgn_w", "sgn_u", "sgn_a")


def feature(
    name: str, w: np.ndarray, a: np.ndarray, u: np.ndarray, dt: float, w_threshold: float
) -> np.ndarray:
    """One feature of every sample (see the module notes), from velocity ``w`` [v],
    acceleration ``a`` [v/s] and input ``u`` [u] sampled every ``dt`` [s]; ``w_threshold``
    [v] is the speed below which w has no sign for ``time_since_reversal``.

    Parameters
    ----------
    name : str
        A feature of :data:`FEATURES`.
    w, a, u : ndarray
        Velocity [v], acceleration [v/s] and input [u] of every sample.
    dt : float
        Sample time [s].
    w_threshold : float
        Speed [v] below which w has no sign.
    """
    if name == "speed":
        return np.abs(w)
    if name == "input":
        return np.abs(u)
    if name == "time_since_reversal":
        return time_since_reversal(np.where(np.abs(w) < w_threshold, 0.0, np.sign(w)), dt)
    if name == "time_since_input_reversal":
        return time_since_reversal(u, dt)
    signed = {"velocity_sign": w, "sgn_w": w, "acceleration_sign": a, "sgn_a": a, "sgn_u": u}
    return np.sign(signed[name])


def features(
    w: np.ndarray, a: np.ndarray, u: np.ndarray, dt: float, w_threshold: float, at: np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """Every feature (:data:`FEATURES`) of every sample, or only of the samples ``at``
    (indices; the features that look back in time are computed at full rate first).

    Parameters
    ----------
    w, a, u : ndarray
        Velocity [v], acceleration [v/s] and input [u] of every sample.
    dt : float
        Sample time [s].
    w_threshold : float
        Speed [v] below which w has no sign.
    at : ndarray, optional
        Indices of the samples wanted (all when None).
    """
    out = {}
    for name in FEATURES:
        x = feature(name, w, a, u, dt, w_threshold)
        out[name] = x if at is None else x[at]
    return out


@dataclass(frozen=True)
class Region:
    """A region of the operating space: ``lo <= feature < hi`` (or a sign).

    Attributes
    ----------
    feature : str
        ``speed``, ``input``, ``time_since_reversal``,
        ``time_since_input_reversal``, ``velocity_sign`` or ``acceleration_sign``.
    lo, hi : float
        Bounds in the feature's unit (for the signs: the sign value, lo = hi).
    description : str
        E.g. ``"|w| < 2.7 rad/s, sign follows sgn(w)"``.
    sign_follows : str
        ``sgn(w)``, ``sgn(u)``, ``sgn(a)`` or ``constant``.
    fraction : float
        Share of the samples in the region.
    energy_fraction : float
        Share of the residual energy in the region.
    """

    feature: str
    lo: float
    hi: float
    description: str
    sign_follows: str
    fraction: float
    energy_fraction: float

    def mask(self, feats: dict[str, np.ndarray]) -> np.ndarray:
        x = feats[self.feature]
        if self.feature in _SIGNS:
            return x == self.lo
        return (x >= self.lo) & (x < self.hi)

    def to_dict(self) -> dict[str, object]:
        return {
            "description": self.description,
            "feature": self.feature,
            "bounds": [self.lo, self.hi],
            "sign_follows": self.sign_follows,
            "fraction": self.fraction,
            "energy_fraction": self.energy_fraction,
        }


def _describe(feature: str, lo: float, hi: float, x: np.ndarray, units: dict[str, str]) -> str:
    if feature in _SIGNS:
        return f"{_SIGNS[feature]} {'>' if lo > 0 else '<'} 0"
    label, unit_key = _ORDERED[feature]
    unit = units.get(unit_key, unit_key)
    if not np.isfinite(lo):
        return f"{label} < {hi:.3g} {unit}"
    if not np.isfinite(hi):
        return f"{label} >= {lo:.3g} {unit}"
    return f"{lo:.3g} <= {label} < {hi:.3g} {unit}"


def sign_pattern(r: np.ndarray, feats: dict[str, np.ndarray], mask: np.ndarray) -> str:
    """Which sign the residual follows inside ``mask``: the best cosine with sgn(w), sgn(u), sgn(a), 1.

    Parameters
    ----------
    r : ndarray
        The balance residual [F].
    feats : dict
        The features of the same samples (:func:`features`).
    mask : ndarray of bool
        The samples of the region.
    """
    rr = r[mask]
    if rr.size == 0 or not np.any(rr):
        return "constant"
    best, label = -1.0, "constant"
    for name, s in (("sgn(w)", feats["sgn_w"]), ("sgn(u)", feats["sgn_u"]), ("sgn(a)", feats["sgn_a"])):
        ss = s[mask]
        den = np.sqrt(np.sum(rr**2) * np.sum(ss**2))
        c = abs(float(np.sum(rr * ss))) / den if den > 0 else 0.0
        if c > best + 1e-9:
            best, label = c, name
    const = abs(float(np.sum(rr))) / np.sqrt(np.sum(rr**2) * rr.size)
    if const > best:
        label = "constant"
    return label


def locate(r: np.ndarray, feats: dict[str, np.ndarray], units: dict[str, str], n_bins: int = 10) -> Region:
    """The region where the residual ``r`` concentrates (see the module notes).

    Parameters
    ----------
    r : ndarray, shape (M,)
        Residual on M samples.
    feats : dict
        Features of the same M samples (:func:`features` at those samples).
    units : dict
        Concrete units for ``v``, ``u`` and ``s`` in the description.
    n_bins : int
        Quantile bins per ordered feature.
    """
    r = np.asarray(r, dtype=float)
    energy = r**2
    total = float(energy.sum()) or 1.0
    n = r.size
    best: tuple[float, str, float, float] | None = None
    for feature in _ORDERED:
        x = feats[feature]
        edges = np.unique(np.quantile(x, np.linspace(0.0, 1.0, n_bins + 1)))
        if edges.size < 2:
            continue
        edges[-1] = np.nextafter(edges[-1], np.inf)
        which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, edges.size - 2)
        e_bin = np.bincount(which, weights=energy, minlength=edges.size - 1) / total
        n_bin = np.bincount(which, minlength=edges.size - 1) / n
        for i in range(edges.size - 1):
            for j in range(i + 1, edges.size):
                frac = n_bin[i:j].sum()
                if not MIN_FRACTION <= frac <= MAX_FRACTION:
                    continue
                score = e_bin[i:j].sum() - frac
                if best is None or score > best[0]:
                    lo = float(edges[i]) if i > 0 else -np.inf
                    hi = float(edges[j]) if j < edges.size - 1 else np.inf
                    best = (score, feature, lo, hi)
    for feature in _SIGNS:
        x = feats[feature]
        for value in (1.0, -1.0):
            m = x == value
            frac = m.mean()
            if MIN_FRACTION <= frac <= MAX_FRACTION:
                score = energy[m].sum() / total - frac
                if best is None or score > best[0]:
                    best = (score, feature, value, value)
    if best is None:  # too few samples to split: the whole record
        best = (0.0, "speed", -np.inf, np.inf)
    _, feature, lo, hi = best
    region = Region(feature, lo, hi, "", "", 0.0, 0.0)
    mask = region.mask(feats)
    pattern = sign_pattern(r, feats, mask)
    text = _describe(feature, lo, hi, feats[feature], units)
    follows = "same sign throughout" if pattern == "constant" else f"sign follows {pattern}"
    return Region(
        feature, lo, hi, f"{text}, {follows}", pattern, float(mask.mean()), float(energy[mask].sum() / total)
    )


__all__ = ["FEATURES", "Region", "feature", "features", "locate", "sign_pattern"]
