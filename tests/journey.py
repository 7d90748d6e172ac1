"""What the journey tests share: the commands *as the docs print them*, and a fresh virtual environment to run them
in, where the journey starts with the docs' own install command.

- :func:`doc_blocks` reads the fenced code blocks of a markdown file with the heading each sits under;
  :func:`shell_lines` splits a shell block into the commands a reader pastes one by one (``\\`` continues a line).
  Tests substitute only placeholders (a host, a port, a token) with :func:`substitute`, never re-type a command.
- :func:`fresh_checkout` copies this checkout (tracked and untracked, not ignored files) where a student would have
  it, and prepares ``.venv`` for the docs' ``python3 -m venv .venv && . .venv/bin/activate && pip install ...``:
  without downloading pybullet, numpy, Django ... again, ``.venv`` sees a folder of links to the running
  environment's copies of exactly the distributions the install asks for (the closure of the base dependencies
  of *this* pyproject.toml plus the named extras, read from their metadata) - no more. A module that the base
  install does not pull in is missing there as it would be after a real ``pip install .``. pip then finds every
  requirement satisfied and installs robokit itself as a real (non-editable) wheel; its build backend
  (setuptools, in pip's isolated build environment) is the only download.
"""

from __future__ import annotations

import importlib.metadata as md
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_FENCE = re.compile(r"^```(\w*)\s*$")


def doc_blocks(path: Path) -> list[tuple[str, str, str]]:
    """``(heading, language, text)`` of every fenced block, in order; heading = the nearest ``#`` line above."""
    heading, out, lines, i = "", [], path.read_text(encoding="utf-8").splitlines(), 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("#"):
            heading = line.lstrip("#").strip()
        match = _FENCE.match(line)
        if match:
            end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
            out.append((heading, match.group(1), "\n".join(lines[i + 1:end])))
            i = end
        i += 1
    return out


def blocks_under(path: Path, heading_start: str, language: str = "sh") -> list[str]:
    """The ``language`` blocks under the heading(s) starting with ``heading_start``."""
    found = [text for head, lang, text in doc_blocks(path) if head.startswith(heading_start) and lang == language]
    assert found, f"{path.name}: no ```{language} block under a heading starting {heading_start!r}"
    return found


def shell_lines(block: str) -> list[str]:
    """The commands of a shell block, one per logical line (``\\`` continuations joined; blank lines skipped)."""
    out, pending = [], ""
    for raw in block.splitlines():
        pending += raw.rstrip()
        if pending.endswith("\\"):
            pending = pending[:-1] + " "
            continue
        if pending.strip():
            out.append(pending.strip())
        pending = ""
    return out


def substitute(text: str, placeholders: dict[str, str]) -> str:
    """``text`` with each placeholder that occurs in it replaced (longest first)."""
    for key in sorted(placeholders, key=len, reverse=True):
        text = text.replace(key, placeholders[key])
    return text


def _requirements(names: list[str], extras: tuple[str, ...]) -> set[str]:
    """The distributions (normalised names) needed by requirement strings ``names``, transitively, from the
    running environment's metadata."""
    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name

    seen: set[str] = set()
    todo = [(Requirement(n), extras) for n in names]
    while todo:
        req, wanted = todo.pop()
        envs = [{"extra": e} for e in wanted] or [{"extra": ""}]
        if req.marker is not None and not any(req.marker.evaluate(env) for env in envs):
            continue
        name = canonicalize_name(req.name)
        key = f"{name}[{','.join(sorted(req.extras))}]"
        if key in seen:
            continue
        seen.add(key)
        dist = md.distribution(req.name)
        todo += [(Requirement(r), tuple(req.extras)) for r in dist.requires or []]
    return {k.split("[")[0] for k in seen}


def dependency_closure(extras: tuple[str, ...] = ()) -> set[str]:
    """What ``pip install '.[extras]'`` of this checkout needs, by distribution name (robokit itself left out)."""
    from robokit.config import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    names = list(project["dependencies"])
    for extra in extras:
        names += [r for r in project["optional-dependencies"][extra] if not r.startswith("robokit")]
    return _requirements(names, ())


def linked_site(dists: set[str], folder: Path) -> Path:
    """A folder of symbolic links to the top-level files and folders of ``dists`` in the running environment."""
    from packaging.utils import canonicalize_name

    folder.mkdir(parents=True)
    found = {canonicalize_name(d.metadata["Name"]): d for d in md.distributions()}
    for name in sorted(dists):
        dist = found[name]
        for file in dist.files or []:
            top = file.parts[0]
            if top == ".." or top.endswith(".pth") or (folder / top).exists():
                continue
            target = Path(str(dist.locate_file(top)))
            if target.exists():
                (folder / top).symlink_to(target)
    return folder


def _copy_checkout(dest: Path) -> None:
    listed = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"], cwd=ROOT,
                            capture_output=True, text=True, check=True).stdout.split("\0")
    for rel in filter(None, listed):
        src = ROOT / rel
        if src.is_file() and not rel.startswith(("results/", "outbox/", "sweeps/")):
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)


def fresh_checkout(tmp: Path, extras: tuple[str, ...] = ()) -> tuple[Path, dict[str, str]]:
    """A copy of this checkout in ``tmp/robokit`` with ``.venv`` prepared (see the module docstring), and the
    environment to run the docs' commands in: ``python3`` is this interpreter's base Python; nothing of the
    running virtual environment leaks in."""
    repo = tmp / "robokit"
    repo.mkdir()
    _copy_checkout(repo)
    base = Path(sys._base_executable if hasattr(sys, "_base_executable") else sys.executable)  # noqa: SLF001
    subprocess.run([str(base), "-m", "venv", "--without-pip", str(repo / ".venv")], check=True)
    site = Path(subprocess.run([str(repo / ".venv" / "bin" / "python"), "-c",
                                "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())
    links = linked_site(dependency_closure(extras), tmp / "deps")
    (site / "00_journey_deps.pth").write_text(f"{links}\n", encoding="utf-8")
    keep = ("HOME", "LANG", "LC_ALL", "TMPDIR", "TERM", "PIP_INDEX_URL", "PIP_EXTRA_INDEX_URL", "HTTPS_PROXY",
            "HTTP_PROXY", "NO_PROXY", "https_proxy", "http_proxy", "no_proxy", "PIP_CERT", "REQUESTS_CA_BUNDLE")
    env = {k: v for k, v in os.environ.items() if k in keep}
    env["PATH"] = os.pathsep.join([str(base.parent), "/usr/local/bin", "/usr/bin", "/bin"])
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    env["OPENBLAS_NUM_THREADS"] = "1"
    return repo, env


def activated(repo: Path, env: dict[str, str]) -> dict[str, str]:
    """``env`` as after ``. .venv/bin/activate``."""
    venv = repo / ".venv"
    return {**env, "VIRTUAL_ENV": str(venv), "PATH": f"{venv / 'bin'}{os.pathsep}{env['PATH']}"}


def sh(command: str, cwd: Path, env: dict[str, str], timeout: float = 900) -> subprocess.CompletedProcess[str]:
    """Run one documented command line with bash, as a reader pasting it would."""
    return subprocess.run(["bash", "-c", command], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)


def ok(proc: subprocess.CompletedProcess[str], command: str) -> str:
    assert proc.returncode == 0, f"`{command}` exited {proc.returncode}:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc.stdout

