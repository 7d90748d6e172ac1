"""The test run does not talk: no test writes past pytest's capture (a ``fault test: 323 requests ...`` line in the
middle of the dots). Figures a test wants to show go to a log record or an assertion message."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent
_PAST_CAPTURE = {"disabled"}  # capsys.disabled(), capfd.disabled(): the bypass pytest offers
_REAL_STREAMS = {"__stdout__", "__stderr__"}


def _escapes(tree: ast.AST) -> list[tuple[int, str]]:
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            owner = node.value.id if isinstance(node.value, ast.Name) else ""
            if node.attr in _PAST_CAPTURE and owner in ("capsys", "capfd", "capsysbinary", "capfdbinary"):
                found.append((node.lineno, f"{owner}.{node.attr}()"))
            if node.attr in _REAL_STREAMS and owner == "sys":
                found.append((node.lineno, f"sys.{node.attr}"))
    return found


@pytest.mark.parametrize("path", sorted(TESTS.glob("*.py")), ids=lambda p: p.name)
def test_no_test_writes_past_pytests_capture(path: Path) -> None:
    escapes = _escapes(ast.parse(path.read_text(encoding="utf-8")))
    hint = "use logging.getLogger(__name__).info(...) or an assertion message"
    assert not escapes, "; ".join(f"{path.name}:{n}: {what} prints past pytest's capture: {hint}"
                                  for n, what in escapes)


def test_the_check_sees_the_old_fault_test_print() -> None:
    old = ("def test_x(capsys):\n    with capsys.disabled():\n"
           "        print(f'fault test: {n} requests for {m} runs')\n")
    assert _escapes(ast.parse(old)) == [(2, "capsys.disabled()")]
