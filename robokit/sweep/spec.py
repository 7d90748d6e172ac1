"""What a sweep is: a config, a grid of overrides, a seed range; expanded into trials with stable keys.

A trial's seed and overrides come from its cell of the grid, never from the order trials run in, so the same sweep
gives the same per-trial results however it is split, resumed or distributed.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robokit.errors import UserError

SWEEP_KEYS = ("config", "seeds", "grid", "set", "metrics", "plugins", "workers", "trial_timeout", "out", "plot")


@dataclass(frozen=True)
class Trial:
    """One run of the sweep: a cell of the grid (its overrides) and a seed.

    Attributes:
        key: Stable identity, ``"<cell>/seed=<n>"``; what ``trials.jsonl`` and resuming go by.
        cell: The cell's key, e.g. ``"behaviour.speed=0.6"`` (``"base"`` when there is no grid).
        overrides: Dotted config key -> value, applied to the raw TOML before validation.
        seed: The run's seed (``world.seed``).
    """

    key: str
    cell: str
    overrides: Mapping[str, Any]
    seed: int


@dataclass(frozen=True)
class SweepSpec:
    """A sweep: the config file, the seeds, the grid over dotted config keys, the figures to aggregate.

    Attributes:
        config: Path of the TOML config.
        seeds: The seeds, as a Python range (``A:B``: A included, B not).
        grid: Dotted key -> the values to try; the cells are the product of the lists.
        fixed: Dotted key -> one value applied to every trial (``--set KEY=V`` with a single value).
        metrics: Names of the behaviour's result figures to aggregate (empty: every numeric one).
        plugins: Importable modules registered as extra plugins in every worker (``--plugin``).
        sweep_file: The sweep file this came from, if any (its digest is recorded in ``sweep.json``).
    """

    config: Path
    seeds: range
    grid: Mapping[str, tuple[Any, ...]] = field(default_factory=dict)
    fixed: Mapping[str, Any] = field(default_factory=dict)
    metrics: tuple[str, ...] = ()
    plugins: tuple[str, ...] = ()
    sweep_file: Path | None = None

    def cells(self) -> list[tuple[str, dict[str, Any]]]:
        """Every cell of the grid as (cell key, overrides), in a stable order (keys sorted, values as given)."""
        keys = sorted(self.grid)
        out = []
        for values in itertools.product(*(self.grid[k] for k in keys)):
            overrides = {**self.fixed, **dict(zip(keys, values, strict=True))}
            cell = ",".join(f"{k}={_show(v)}" for k, v in zip(keys, values, strict=True)) or "base"
            out.append((cell, overrides))
        return out

    def trials(self) -> list[Trial]:
        """The cells × the seeds: cell by cell, seeds in order."""
        return [Trial(f"{cell}/seed={seed}", cell, overrides, seed)
                for cell, overrides in self.cells() for seed in self.seeds]

    def identity(self, config_text: str) -> dict[str, Any]:
        """What must not change between a sweep and its resumption (the config text and the fixed overrides)."""
        digest = hashlib.sha256(config_text.encode("utf-8")).hexdigest()
        return {"config_sha256": digest, "fixed": {k: self.fixed[k] for k in sorted(self.fixed)},
                "plugins": list(self.plugins)}


def _show(value: Any) -> str:
    """A value as it appears in a cell key: JSON, so 0.3 stays 0.3 and strings are quoted."""
    return json.dumps(value, separators=(",", ":"))


def parse_seeds(text: str, where: str = "--seeds") -> range:
    """``"A:B"`` as a Python range (A included, B not); a single ``"N"`` is the one seed N."""
    parts = text.split(":")
    try:
        numbers = [int(p) for p in parts]
    except ValueError:
        raise UserError(f"{where}: expected A:B (seeds A..B-1) or N, got {text!r}") from None
    if len(numbers) == 1:
        numbers = [numbers[0], numbers[0] + 1]
    if len(numbers) != 2 or numbers[0] < 0 or numbers[1] <= numbers[0]:
        raise UserError(f"{where}: expected A:B with 0 <= A < B, got {text!r}")
    return range(numbers[0], numbers[1])


def parse_value(text: str) -> Any:
    """A command-line value as TOML would read it: numbers, booleans, quoted strings, arrays; else a bare string."""
    from robokit.config import tomllib

    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def parse_set(items: Sequence[str]) -> tuple[dict[str, tuple[Any, ...]], dict[str, Any]]:
    """``--set KEY=V1,V2`` options into (grid, fixed): one value fixes the key, several make a grid axis.

    Commas inside brackets or quotes do not split (``--set behaviour.place_position=[0.4,0.3,0.03]``).
    """
    grid: dict[str, tuple[Any, ...]] = {}
    fixed: dict[str, Any] = {}
    for item in items:
        key, sep, rest = item.partition("=")
        key = key.strip()
        if not sep or not key or not rest.strip():
            raise UserError(f"--set: expected KEY=V1,V2,... (e.g. behaviour.speed=0.6,1.2), got {item!r}")
        values = tuple(parse_value(v.strip()) for v in _split_top(rest))
        if key in grid or key in fixed:
            raise UserError(f"--set: {key} is given twice")
        if len(values) == 1:
            fixed[key] = values[0]
        else:
            grid[key] = values
    return grid, fixed


def _split_top(text: str) -> list[str]:
    """Split on commas that are not inside brackets, braces or quotes."""
    parts, depth, quote, start = [], 0, "", 0
    for i, ch in enumerate(text):
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def tidy(path: str | Path) -> Path:
    """``path`` with ``.`` and ``dir/..`` taken out, still relative if it was (``configs/sweeps/../x.toml`` ->
    ``configs/x.toml``): the form printed and stored. Lexical, like the shell's ``cd``: a symlinked folder
    followed by ``..`` is read as its name says."""
    return Path(os.path.normpath(path))


def load_sweep_file(path: str | Path) -> tuple[SweepSpec, dict[str, Any]]:
    """Read a sweep file (TOML) into a spec plus the run options it sets (workers, out, trial_timeout, plot).

    The file's keys: ``config`` (relative to the sweep file), ``seeds = "A:B"`` or ``[A, B]``, ``[grid]`` (dotted
    key = list of values), ``[set]`` (dotted key = one value for every trial), ``metrics``, ``plugins``.
    """
    from robokit.config import read_toml

    path = Path(path)
    raw = read_toml(path)
    unknown = [k for k in raw if k not in SWEEP_KEYS]
    if unknown:
        raise UserError(f"{path}: unknown key {unknown[0]!r}; valid keys: {', '.join(SWEEP_KEYS)}")
    if not isinstance(raw.get("config"), str):
        raise UserError(f"{path}: config: expected the path of a robokit config, e.g. config = \"robot.toml\"")
    seeds_raw = raw.get("seeds", "0:1")
    if isinstance(seeds_raw, list) and len(seeds_raw) == 2 and all(isinstance(s, int) for s in seeds_raw):
        seeds_raw = f"{seeds_raw[0]}:{seeds_raw[1]}"
    if not isinstance(seeds_raw, str):
        raise UserError(f"{path}: seeds: expected \"A:B\" or [A, B], got {seeds_raw!r}")
    grid = {k: tuple(v) for k, v in _flatten(raw.get("grid", {}), path, "grid").items()}
    for key, values in grid.items():
        if not values:
            raise UserError(f"{path}: grid.{key}: expected a non-empty list of values")
    fixed = _flatten(raw.get("set", {}), path, "set", lists_are_values=True)
    spec = SweepSpec(
        config=tidy(path.parent / raw["config"]),
        seeds=parse_seeds(seeds_raw, f"{path}: seeds"),
        grid=grid, fixed=fixed,
        metrics=tuple(_strings(raw.get("metrics", []), path, "metrics")),
        plugins=tuple(_strings(raw.get("plugins", []), path, "plugins")),
        sweep_file=path,
    )
    options: dict[str, Any] = {k: raw[k] for k in ("workers", "trial_timeout", "out", "plot") if k in raw}
    if "out" in options:
        options["out"] = str(tidy(path.parent / options["out"]))
    return spec, options


def _flatten(table: Any, path: Path, section: str, *, lists_are_values: bool = False) -> dict[str, Any]:
    """``{"behaviour": {"speed": [..]}}`` or ``{"behaviour.speed": [..]}`` -> ``{"behaviour.speed": [..]}``."""
    if not isinstance(table, Mapping):
        raise UserError(f"{path}: {section}: expected a table of dotted config keys")
    out: dict[str, Any] = {}
    for key, value in table.items():
        if isinstance(value, Mapping):
            for sub, v in _flatten(value, path, f"{section}.{key}", lists_are_values=lists_are_values).items():
                out[f"{key}.{sub}"] = v
        elif lists_are_values or isinstance(value, list):
            out[key] = value
        else:
            raise UserError(f"{path}: {section}.{key}: expected a list of values to try, got {value!r}")
    return out


def _strings(value: Any, path: Path, key: str) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise UserError(f"{path}: {key}: expected a list of names, got {value!r}")
    return value

