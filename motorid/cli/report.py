"""What a command prints: human text on stderr, one JSON object on stdout."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd


def jsonable(value: Any) -> Any:
    """numpy and pandas values as plain JSON (NaN and inf as null)."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.floating | float):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, Path):
        return str(value)
    return value


def emit_json(payload: dict[str, Any]) -> None:
    """Print ``payload`` as one JSON object on stdout."""
    sys.stdout.write(json.dumps(jsonable(payload), indent=2) + "\n")


def say(text: str = "") -> None:
    """Print a line of human text on stderr."""
    sys.stderr.write(text + "\n")


def frame_records(df: pd.DataFrame) -> list[dict[str, Any]]:
    """A DataFrame's rows as dicts, its index as a named field."""
    return [
        {df.index.name or "index": idx, **row}
        for idx, row in zip(df.index, df.to_dict("records"), strict=True)
    ]


def say_params(prefix: str, params: dict[str, Any]) -> None:
    """One line per estimated parameter."""
    for key, value in params.items():
        say(f"  {prefix}{key} = {np.array2string(np.asarray(value), precision=5)}")
