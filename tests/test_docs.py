"""The docs are tested: every ``robokit`` command in README.md and docs/*.md parses with the real argument parser;
the fast ones (validate, inspect, plugins, graph, outbox list, --help, --version) run from where the docs say to
stand and exit as documented; short runs of shipped configs run in the slow pass; no absolute paths from the
writer's machine; sample outputs match what their commands print now (``python -m robokit.checks.docs_samples``).

Commands are read from fenced blocks (```sh, ```bash, ```console or plain ``` blocks whose lines start with
``$ robokit``); ``\\`` continues a line, ``#`` starts a comment, ``cd DIR`` in a block moves the commands after it.
Commands other helpers add later (serve, sweep, video...) are parse-checked like every other: only the list of
fast subcommands below is executed.
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]  # the lessons (both languages) too
FAST = {"validate", "inspect", "plugins", "graph"}
SHELL_FENCES = ("```sh", "```bash", "```console", "```shell")


@dataclass(frozen=True)
class Command:
    """One shell command from the docs: where it is, the folder it runs in (relative to the root), its words, and
    whether the docs show it failing (an ``robokit: error:`` line right after it)."""

    where: str
    cwd: str
    argv: tuple[str, ...]
    shows_error: bool
    needs_install: bool = False
    """An earlier line of its block installs a package (``pip install``): it needs that package."""

    def __str__(self) -> str:
        return f"{self.where}: {shlex.join(self.argv)}"


def _blocks(path: Path) -> list[tuple[int, list[str]]]:
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks, i = [], 0
    while i < len(lines):
        fence = lines[i].strip()
        if fence.startswith("```"):
            end = next((j for j in range(i + 1, len(lines)) if lines[j].strip().startswith("```")), len(lines))
            body = lines[i + 1:end]
            if fence in SHELL_FENCES or (fence == "```" and any(b.startswith("$ robokit") for b in body)):
                blocks.append((i + 2, body))
            i = end + 1
        else:
            i += 1
    return blocks


def _commands(path: Path) -> list[Command]:
    found = []
    for first, body in _blocks(path):
        cwd, pending, start, installs = ".", "", first, False
        for offset, raw in enumerate(body + [""]):
            line = raw.rstrip()
            prompted = line.startswith("$ ")
            if not pending:
                start = first + offset
                if line and not prompted and any(b.startswith("$ ") for b in body):
                    continue  # output shown after a `$ ` command
                line = line[2:] if prompted else line
            pending += line.rstrip("\\").strip() + " "
            if line.endswith("\\"):
                continue
            text, pending = pending.strip(), ""
            if not text:
                continue
            words = shlex.split(text, comments=True)
            cut = next((i for i, w in enumerate(words) if w in ("|", "||", "&&", ";", ">", ">>", "2>")), len(words))
            words = words[:cut]  # the robokit part of a pipeline
            if words[:2] == ["pip", "install"]:
                installs = True
            if words[:1] == ["cd"] and len(words) == 2:
                cwd = str(Path(cwd) / words[1])
            elif words[:1] == ["robokit"]:
                following = body[offset + 1] if offset + 1 < len(body) else ""
                found.append(Command(f"{path.relative_to(ROOT)}:{start}", cwd, tuple(words[1:]),
                                     following.startswith("robokit: error:"), installs))
    return found


COMMANDS = [c for doc in DOCS for c in _commands(doc)]


def test_the_docs_have_commands_to_check() -> None:
    assert len(COMMANDS) >= 30
    assert {c.argv[0] for c in COMMANDS if c.argv} >= {"run", "validate", "plugins", "inspect", "graph", "outbox"}


@pytest.mark.parametrize("command", COMMANDS, ids=str)
def test_every_documented_command_parses(command: Command) -> None:
    """The subcommand and every flag exist (parse only: nothing runs)."""
    from robokit.cli import _parser

    argv = [a for a in command.argv if a != "--debug"]
    if "--help" in argv or "-h" in argv or "--version" in argv:
        argv = [a for a in argv if a not in ("--help", "-h", "--version")] or ["plugins"]
    try:
        _parser().parse_args(argv)
    except SystemExit as exc:
        pytest.fail(f"{command}: does not parse (exit {exc.code})")


def _fast(command: Command) -> bool:
    argv = command.argv
    if not argv or "--gui" in argv or command.needs_install:
        return False
    if "--help" in argv or "--version" in argv:
        return True
    if "robokit-example-plugin" in " ".join(argv) or "configs/imu" in " ".join(argv):
        return False  # the example plugin's own commands need it installed: tested in test_plugins_example
    return argv[0] in FAST or argv[:2] == ("outbox", "list")


@pytest.mark.parametrize("command", [c for c in COMMANDS if _fast(c)], ids=str)
def test_fast_documented_commands_run_as_documented(command: Command, capsys, monkeypatch) -> None:
    """Run in-process through ``robokit.cli.main`` (the command's own code path), from the documented folder."""
    from robokit.cli import main

    monkeypatch.chdir(ROOT / command.cwd)
    try:
        code = main(list(command.argv))
    except SystemExit as exc:  # --help and --version end through argparse
        code = exc.code if isinstance(exc.code, int) else 0
    err = capsys.readouterr().err
    expected = 2 if command.shows_error else 0
    assert code == expected, f"{command}: exit {code}\n{err[-1500:]}"
    assert "Traceback" not in err


def _shipped_run(command: Command) -> bool:
    argv = command.argv
    return (argv[:1] == ("run",) and len(argv) > 1 and argv[1].startswith("configs/") and "--gui" not in argv
            and "--report-url" not in argv)


def _first_of_each(commands: list[Command]) -> list[Command]:
    """One of each command (the lessons show the same command in both languages)."""
    seen: set[tuple[str, tuple[str, ...]]] = set()
    return [c for c in commands if (c.cwd, c.argv) not in seen and not seen.add((c.cwd, c.argv))]


@pytest.mark.slow
@pytest.mark.parametrize("command", _first_of_each([c for c in COMMANDS if _shipped_run(c)]), ids=str)
def test_documented_runs_of_shipped_configs_succeed(command: Command, tmp_path: Path) -> None:
    """``robokit run configs/...`` as written, from the repository root (results in a temporary folder)."""
    for name in ("configs", "examples"):
        (tmp_path / name).symlink_to(ROOT / name)
    proc = subprocess.run([sys.executable, "-m", "robokit.cli", *command.argv], cwd=tmp_path, capture_output=True,
                          text=True, timeout=3600)
    assert proc.returncode == 0, f"{command}: exit {proc.returncode}\n{proc.stdout[-800:]}\n{proc.stderr[-800:]}"


_PATH_ARG = re.compile(r"\.(toml|urdf|sdf|py)$")


@pytest.mark.parametrize("command", [c for c in COMMANDS if any(_PATH_ARG.search(a) for a in c.argv)
                                     and c.argv[0] in ("run", "validate", "inspect")], ids=str)
def test_files_named_by_commands_exist_where_the_docs_stand(command: Command) -> None:
    """Config and URDF paths resolve from the folder the docs say to run in (the repository root unless a ``cd``
    in the block says otherwise), else among pybullet_data's and robokit's bundled files; the guide's illustrations
    of a package of one's own (``configs/imu.toml``) are skipped."""
    for arg in command.argv:
        if not _PATH_ARG.search(arg) or "/" not in arg or command.shows_error or arg.startswith("configs/imu"):
            continue
        import pybullet_data

        places = [ROOT / command.cwd, Path(pybullet_data.getDataPath()), ROOT / "robokit" / "data"]
        assert any((place / arg).exists() for place in places), f"{command}: {arg} not found from {command.cwd}"


def test_the_example_plugin_is_installed_from_where_the_guide_stands() -> None:
    """docs/plugins.md installs the example with ``pip install -e ./robokit-example-plugin``: that path must exist
    from the folder the guide's block is in."""
    text = (ROOT / "docs" / "plugins.md").read_text(encoding="utf-8")
    for first, body in _blocks(ROOT / "docs" / "plugins.md"):
        cwd = ROOT
        for line in body:
            words = shlex.split(line, comments=True)
            if words[:1] == ["cd"]:
                cwd = cwd / words[1]
            if words[:2] == ["pip", "install"]:
                target = words[-1]
                if target.startswith("./") or target.startswith("../"):
                    assert (cwd / target / "pyproject.toml").exists(), f"docs/plugins.md:{first}: {line}"
    assert "robokit-example-plugin" in text


_ABSOLUTE = re.compile(r"(?<![\w.])/(home/(?!you/)|Users/|work/|root/|tmp/pytest|opt/[a-z]+/simple/)")


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_absolute_paths_from_the_writers_machine(doc: Path) -> None:
    for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
        assert not _ABSOLUTE.search(line), f"{doc.relative_to(ROOT)}:{n}: {line.strip()}"


@pytest.mark.slow
def test_sample_outputs_are_what_their_commands_print() -> None:
    """Every ``<!-- sample: ... -->`` block matches a fresh run of its command (modulo run ids and times)."""
    proc = subprocess.run([sys.executable, "-m", "robokit.checks.docs_samples", "--check"], cwd=ROOT,
                          capture_output=True,
                          text=True, timeout=3600)
    assert proc.returncode == 0, proc.stdout + proc.stderr[-1500:]


def test_the_sample_generator_reads_this_repository() -> None:
    from robokit.checks.docs_samples import ROOT as SAMPLES_ROOT
    from robokit.checks.docs_samples import doc_files

    assert SAMPLES_ROOT == ROOT and set(doc_files()) == set(DOCS)


def test_the_stale_samples_named_in_the_issue_are_generated() -> None:
    from robokit.checks.docs_samples import samples

    marked = {str(p.relative_to(ROOT)): [c for _, c, _, _ in samples(p)] for p in DOCS}
    assert any("drop_test" in c for c in marked["docs/cli.md"])  # the RunResult
    # the main job's summary (sim time 7.93 s, total_time 7.9292) is generated where it is shown
    assert "robokit run configs/sort_robot.toml" in marked["README.md"]
    assert "robokit run configs/sort_robot.toml" in marked["docs/vision.md"]
    assert any("payload" in c for c in marked["docs/reporting.md"])
    assert any("patrol_robot" in c for c in marked["docs/mobile.md"])
