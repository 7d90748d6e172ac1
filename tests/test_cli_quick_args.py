"""``robokit run CONFIG [OPTIONS]`` is read without argparse when argparse could only read it one way: the result
must then be exactly argparse's, and anything else must be left to argparse (which reports the errors)."""

from __future__ import annotations

import random
import subprocess
import sys
from typing import Any

import pytest

from robokit import cli

WORDS = ["run", "x.toml", "y.toml", "--gui", "--json", "--quiet", "--gui-hold", "--no-record", "--save-frames",
         "--seed", "7", "-3", "0x10", "--max-time", "2.5", "0", "inf", "nan", "--max-wall", "1e3", "--trace", "t.jsonl",
         "--student", "ann", "", "--project", "--report-url", "http://h/x", "--pose-hz", "-1", "60", "--video",
         "v.mp4", "--qui", "--seed=3", "-h", "--help", "--version", "--", "-", "--unknown", "5_0", " 4 ", "run"]


def _shown(args: Any) -> dict[str, str]:
    """Every attribute as its repr, with its type (so that nan equals nan, and 1 differs from 1.0 or True)."""
    return {k: f"{type(v).__name__} {v!r}" for k, v in vars(args).items()}


def _argparse(argv: list[str]) -> dict[str, str] | None:
    """argparse's reading of ``argv``, or None when it refuses it."""
    try:
        return _shown(cli._parser(argv[0] if argv else None).parse_args(argv))
    except SystemExit:
        return None


def _quick(argv: list[str]) -> dict[str, str] | None:
    args = cli._quick_run_args(argv)
    return None if args is None else _shown(args)


@pytest.mark.parametrize("argv", [
    ["run", "x.toml"],
    ["run", "x.toml", "--quiet"],
    ["run", "--json", "x.toml", "--seed", "4", "--max-time", "0.5", "--max-wall", "30", "--trace", "t.jsonl"],
    ["run", "x.toml", "--student", "ann", "--project", "p", "--report-url", "http://h/x", "--pose-hz", "0"],
    ["run", "x.toml", "--gui", "--gui-hold", "--no-record", "--save-frames", "--video", "v.mp4"],
    ["run", "x.toml", "--seed", "1", "--seed", "2"],  # the last one wins, as in argparse
    ["run", "x.toml", "--student", ""],
])
def test_common_command_lines_are_read_as_argparse_reads_them(argv: list[str]) -> None:
    quick = _quick(argv)
    assert quick is not None
    assert quick == _argparse(argv)


@pytest.mark.parametrize("argv", [
    ["run"], ["run", "x.toml", "y.toml"], ["run", "x.toml", "--qui"], ["run", "x.toml", "--seed=3"],
    ["run", "x.toml", "--seed", "-3"], ["run", "x.toml", "--seed", "x"], ["run", "x.toml", "--max-time", "0"],
    ["run", "x.toml", "-h"], ["run", "x.toml", "--help"], ["run", "x.toml", "--"], ["run", "-"],
    ["run", "x.toml", "--max-time"], ["validate", "x.toml"], ["--version"], [],
])
def test_anything_else_is_left_to_argparse(argv: list[str]) -> None:
    assert cli._quick_run_args(argv) is None


def test_random_command_lines_agree_with_argparse() -> None:
    """Whenever the quick reader answers, argparse reads the same; when argparse refuses, the quick reader declines."""
    gen = random.Random(15)
    answered = 0
    for _ in range(3000):
        argv = ["run"] + [gen.choice(WORDS) for _ in range(gen.randint(0, 6))]
        quick = _quick(argv)
        if quick is None:
            continue
        answered += 1
        assert quick == _argparse(argv), argv
    assert answered > 200  # this seed: 298 of 3000 lines are ones the quick reader answers


def test_a_bad_value_is_still_argparses_one_line_error(tmp_path: Any) -> None:
    proc = subprocess.run([sys.executable, "-m", "robokit.cli", "run", "x.toml", "--max-time", "0"],
                          capture_output=True, text=True, cwd=tmp_path, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr == ("robokit: error: argument --max-time: expected a positive, finite number of seconds, got "
                           "'0' (see: robokit run --help)\n")
