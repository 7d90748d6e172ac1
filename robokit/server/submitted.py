"""Checking a submitted config against its assignment: only the keys students may change, and robokit's own
validation. Every refusal is one line naming the key."""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from robokit.server.assignments import Assignment


class SubmissionError(Exception):
    """A submitted config that cannot be accepted; ``field`` names the key (``config`` for the file itself)."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


def flatten(tree: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """``(dotted key, value)`` for every leaf of a TOML tree; a list of tables is a leaf (compared whole)."""
    if isinstance(tree, dict) and (tree or not prefix):
        for key, value in tree.items():
            yield from flatten(value, f"{prefix}.{key}" if prefix else str(key))
    else:
        yield prefix, tree


def changed_keys(official: dict[str, Any], submitted: dict[str, Any]) -> list[str]:
    """Dotted keys whose value differs, that were added, or that were removed, in the order of the files."""
    a, b = dict(flatten(official)), dict(flatten(submitted))
    return [k for k in [*a, *(k for k in b if k not in a)] if a.get(k, _MISSING) != b.get(k, _MISSING)]


_MISSING = object()


def parse_toml(text: str, field: str = "config") -> dict[str, Any]:
    from robokit.config import tomllib

    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SubmissionError(field, f"TOML syntax error: {exc}") from None


def check_submission(assignment: Assignment, text: str, *, validate: bool = True) -> None:
    """Refuse a config that changes a key students may not change, or that robokit's config check refuses
    (``validate``; off for a config that uses types of the student's own plugin: the sandbox checks it then).

    Raises:
        SubmissionError: naming the first such key.
    """
    submitted = parse_toml(text)
    official = parse_toml(assignment.config_text, "official config")
    for key in changed_keys(official, submitted):
        if key == "world.seed":
            continue  # the official seeds replace it anyway
        if not assignment.may_change(key):
            allowed = ", ".join(assignment.allowed_keys) or "none"
            raise SubmissionError(key, f"students may not change this key in {assignment.name!r} "
                                       f"(keys you may change: {allowed})")
    if validate:
        validate_config(text)


def validate_config(text: str, source: str = "submitted config") -> None:
    """robokit's own config validation (the plugins' schemas included), as ``robokit validate`` does it."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="robokit-validate-") as scratch:
        problem = config_problem(text, source, scratch, {})
    if problem is not None:
        raise SubmissionError(*problem)


def config_problem(text: str, source: str, base_dir: str, overrides: dict[str, Any],
                   modules: tuple[str, ...] = ()) -> tuple[str, str] | None:
    """The first problem robokit's config check finds, as ``(field, one-line message)``; None for a config that
    loads. ``modules``: a student's plugin modules, imported as extra plugins first (only ever in the sandbox's
    process, :func:`robokit.server.sandbox.check_sandboxed`); their failures are field ``plugin``."""
    from robokit.errors import UserError
    from robokit.sweep.trial import build_trial_config, plugins_for

    try:
        plugins = plugins_for(modules)
        build_trial_config(text, source, base_dir, overrides, plugins)
    except UserError as exc:
        key = getattr(exc, "key", None) or "config"
        return str(key), one_line(getattr(exc, "message", None) or str(exc))
    except Exception as exc:
        if not modules:
            raise  # robokit's own plugins failing is a bug, not the student's
        return "plugin", one_line(f"your plugin {', '.join(modules)} failed while loading the config: "
                                  f"{type(exc).__name__}: {exc}")
    return None


def one_line(text: str) -> str:
    return " ".join(text.split())[:500]
