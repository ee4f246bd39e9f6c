"""``motorid --help`` says what each command accepts: every option has help text and shows its
default; the estimators' and the effects' names are listed; ``--help-params`` names an estimator's
keys. Warnings come out as ``motorid: warning: ...``, once per cause."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from motorid.cli import build_parser, main
from motorid.drive.effects import names as effect_names
from motorid.estimators import available

MOTORID = Path(sys.executable).with_name("motorid")


def parsers(parser: argparse.ArgumentParser, path: tuple[str, ...] = ("motorid",)):
    """Every (sub)command's parser, with its command line."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from parsers(sub, (*path, name))


COMMANDS = list(parsers(build_parser()))


@pytest.mark.parametrize(("path", "parser"), COMMANDS, ids=[" ".join(p) for p, _ in COMMANDS])
def test_every_option_has_help_and_shows_its_default(path, parser):
    text = parser.format_help()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            continue
        name = "/".join(action.option_strings) or action.dest
        assert action.help, f"{' '.join(path)} {name} has no help text"
        meaningful = action.default not in (None, argparse.SUPPRESS, []) and not isinstance(
            action, (argparse._StoreTrueAction, argparse._StoreFalseAction)
        )
        if action.option_strings and meaningful:
            assert parser._get_formatter()._get_help_string(action).count("default") >= 1, (
                f"{' '.join(path)} {name}: its default {action.default!r} is not shown"
            )
    assert "(default: None)" not in text


def test_a_help_text_without_its_default_fails_the_check():
    """The check above can fail: an option whose help leaves out its default gets it appended by the
    formatter, and an option without help is caught."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["sweep"]
    action = sub.add_argument("--example", type=int, default=7, help="an example")
    assert sub._get_formatter()._get_help_string(action) == "an example (default: %(default)s)"
    assert "an example (default: 7)" in " ".join(sub.format_help().split())
    bare = sub.add_argument("--bare", type=int)
    assert not bare.help


def help_of(capsys, *argv: str) -> str:
    assert main([*argv, "--help"]) == 0
    return " ".join(capsys.readouterr().out.split())


@pytest.mark.parametrize("command", [("identify",), ("run",), ("fleet", "identify")])
def test_estimator_names_are_listed(capsys, command):
    text = help_of(capsys, *command)
    for name in available():
        assert name in text, f"motorid {' '.join(command)} --help does not list {name}"


@pytest.mark.parametrize("command", [("doctor",), ("fleet", "doctor")])
def test_effect_names_are_listed(capsys, command):
    text = help_of(capsys, *command)
    for name in effect_names():
        assert name in text, f"motorid {' '.join(command)} --help does not list {name}"


def test_help_params_names_the_keys_of_the_chosen_estimator(capsys):
    assert main(["identify", "--estimator", "friction-ekf", "--help-params"]) == 0
    out = capsys.readouterr().out
    keys = {line.split()[0] for line in out.splitlines()[1:] if line.startswith("  ")}
    assert {"R", "coulomb0", "viscous0", "stribeck", "divergence_nis"} <= keys
    assert "  R [None]" in out
    assert main(["identify", "--estimator", "arx-rls", "--help-params"]) == 0
    out = capsys.readouterr().out
    assert "  na [required]: Order of A(q^-1)" in out and "  lam [1.0]" in out and "coulomb0" not in out
    assert main(["identify", "--estimator", "no-such", "--help-params"]) == 2
    assert "unknown estimator 'no-such'" in capsys.readouterr().err


def test_a_warning_is_said_once_in_the_command_line_form(tmp_path):
    """A logger's jittered stamps, read twice by one command (the record and its --validate record):
    one line ``motorid: warning: ...``, not the logging module's ``WARNING motorid.io.records: ...``."""
    rng = np.random.default_rng(0)
    n = 2000
    u = np.sin(2 * np.pi * 0.5 * 0.01 * np.arange(n)) * 50
    log = pd.DataFrame({"time_ms": 1000 + 10 * np.arange(n) + rng.integers(-1, 2, n), "pwm": u.round(2),
                        "rpm": (20 * u + rng.normal(0, 1, n)).round(3)})  # fmt: skip
    log.to_csv(tmp_path / "logger.csv", index=False)
    argv = [str(MOTORID), "identify", "logger.csv", "--time", "time_ms", "--time-unit", "ms", "--input", "pwm",
            "--output", "rpm", "--estimator", "arx-rls", "--validate", "logger.csv", "-q"]  # fmt: skip
    done = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONUNBUFFERED": "1"})  # fmt: skip
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("motorid: warning: logger.csv: time stamps jitter by up to")


def test_simulate_friction_lists_the_parameters_a_mass_takes(capsys):
    text = help_of(capsys, "simulate")
    for name in ("coulomb", "stribeck_velocity", "viscous_asymmetry", "breakaway_excess", "bristle_damping"):
        assert name in text.split("PARAM is one of:")[1], name
    assert "input_delay" not in text.split("PARAM is one of:")[1]  # not an effect a mass holds
