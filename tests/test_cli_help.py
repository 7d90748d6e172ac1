"""Every command's ``--help`` (and ``-h``) prints its usage and exits 0: ``robokit manage --help`` was an
"unrecognized arguments" error (its parser hands everything after COMMAND to Django, and had no help of its own)."""

from __future__ import annotations

import contextlib
import io
import re

import pytest

from robokit.cli import main


def _commands() -> list[str]:
    """The commands ``robokit --help`` lists (a name indented by four spaces under ``COMMAND``)."""
    shown = io.StringIO()
    with contextlib.redirect_stdout(shown), contextlib.suppress(SystemExit):
        main(["--help"])
    return re.findall(r"^    ([a-z][a-z-]*)(?:\s|$)", shown.getvalue(), flags=re.MULTILINE)


def test_the_command_list_includes_manage() -> None:
    assert "manage" in _commands() and "run" in _commands()


@pytest.mark.parametrize("flag", ["--help", "-h"])
@pytest.mark.parametrize("command", _commands())
def test_help_prints_usage_and_exits_0(command: str, flag: str, capsys: pytest.CaptureFixture[str]) -> None:
    code: int | str | None
    try:
        code = main([command, flag])
    except SystemExit as stop:
        code = stop.code
    out, err = capsys.readouterr()
    assert code in (0, None), err
    assert out.startswith(f"usage: robokit {command}"), (out[:200], err)
    assert "error" not in err
