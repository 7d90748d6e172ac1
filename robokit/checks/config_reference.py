"""The config reference page, generated from the schemas: ``python -m robokit.checks.config_reference [--check]``.

Writes docs/config-reference.md (English) and docs/config-reference.ko.md (Korean: the fixed prose translated, keys
and the schemas' own descriptions as they are in the code). Every core section and key, every built-in plugin
type's keys: type, default, bounds, and what the schema says of it (units included). ``--check`` rewrites nothing
and exits 1 if a committed page differs from what the schemas give now.
"""

from __future__ import annotations

import argparse
import inspect
import math
import re
import sys
import types
import typing
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from robokit.checks.config_reference_text import TEXT, WORDS
from robokit.config import sections as _s
from robokit.config.sections import FLOAT_LIMIT, Bounds, Section

ROOT = Path(__file__).resolve().parents[2]
PAGES = {"en": ROOT / "docs" / "config-reference.md", "ko": ROOT / "docs" / "config-reference.ko.md"}
KINDS = ("sensor", "actuator", "behaviour", "reporter", "task")


@dataclass(frozen=True)
class Key:
    """One key of a schema, as the page shows it."""

    name: str
    type_text: str
    default: str
    bounds: str
    meaning: str
    nested: type | None = None
    """A table of its own (a nested schema), documented below its parent."""


# ----------------------------------------------------------------- reading schemas
def keys_of(schema: type) -> list[Key]:
    """The keys of a light :class:`Section` or a pydantic model, in declaration order."""
    if issubclass(schema, Section):
        return _section_keys(schema)
    return _pydantic_keys(schema)


def _section_keys(schema: type[Section]) -> list[Key]:
    hints = _s._field_types(schema)
    notes = _attribute_notes(schema)
    out = []
    for name, spec in schema._fields.items():
        tp = hints[name]
        bounds = _merge(spec.bounds, tp)
        if spec.required:
            default = "(required)"
        else:
            default = _toml(spec.factory() if spec.factory is not _s._MISSING else spec.default)
        out.append(Key(name, type_name(tp), default, _bounds_text(bounds, tp),
                       _meaning(bounds.description, tp, notes.get(name, "")), _nested(tp)))
    return out


def _pydantic_keys(schema: type) -> list[Key]:
    from pydantic_core import PydanticUndefined

    notes = _attribute_notes(schema)
    out = []
    for name, info in schema.model_fields.items():  # type: ignore[attr-defined]
        tp = info.annotation
        bounds = Bounds()
        for extra in info.metadata:
            for attr in ("ge", "gt", "le", "lt", "min_length"):
                if getattr(extra, attr, None) is not None:
                    setattr(bounds, attr, getattr(extra, attr))
        bounds = _merge(bounds, tp)
        if info.default_factory is not None:
            default = _toml(info.default_factory())  # type: ignore[call-arg]
        elif info.default is PydanticUndefined:
            default = "(required)"
        else:
            default = _toml(info.default)
        out.append(Key(name, type_name(tp), default, _bounds_text(bounds, tp),
                       _meaning(info.description or "", tp, notes.get(name, "")), _nested(tp)))
    return out


def _merge(bounds: Bounds, tp: Any) -> Bounds:
    """The field's own bounds, completed by those of its type (``Length`` is ``> 0, <= 1000``, metres)."""
    for extra in _annotated_bounds(tp):
        bounds = bounds.over(extra)
    return bounds


def _annotated_bounds(tp: Any) -> Iterator[Bounds]:
    """Bounds carried by ``Annotated`` on the type itself or, for a tuple, on its items (the first one)."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin is Annotated:
        for extra in tp.__metadata__:
            if isinstance(extra, Bounds):
                yield extra
            elif hasattr(extra, "metadata") or hasattr(extra, "description"):  # a pydantic FieldInfo
                yield _from_field_info(extra)
        yield from _annotated_bounds(args[0])
    elif origin in (typing.Union, types.UnionType):
        for arg in args:
            if arg is not type(None):
                yield from _annotated_bounds(arg)
                return
    elif origin is tuple and args:
        yield from _annotated_bounds(args[0])


def _from_field_info(info: Any) -> Bounds:
    bounds = Bounds(description=getattr(info, "description", "") or "")
    for extra in getattr(info, "metadata", ()):
        for attr in ("ge", "gt", "le", "lt"):
            if getattr(extra, attr, None) is not None:
                setattr(bounds, attr, getattr(extra, attr))
    return bounds


def _nested(tp: Any) -> type | None:
    """The schema of a nested table (``mount = {...}``, ``bins.NAME``), if the field holds one."""
    if isinstance(tp, type) and _is_schema(tp):
        return tp
    for arg in typing.get_args(tp):
        found = _nested(arg)
        if found is not None:
            return found
    return None


def _is_schema(tp: type) -> bool:
    return issubclass(tp, Section) or hasattr(tp, "model_fields")


def type_name(tp: Any) -> str:
    """A field type as a config writer reads it: ``float``, ``[float, float, float]``, ``"a" or "b"``..."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin is Annotated:
        return type_name(args[0])
    if origin in (typing.Union, types.UnionType):
        rest = [a for a in args if a is not type(None)]
        text = " or ".join(type_name(a) for a in rest)
        return f"{text} (optional)" if len(rest) < len(args) else text
    if origin is Literal:
        return " or ".join(f'"{a}"' if isinstance(a, str) else _toml(a) for a in args)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return f"[{_inner(args[0])}, ...]"
        return "[" + ", ".join(_inner(a) for a in args) + "]"
    if origin in (list, set, frozenset):
        return f"[{_inner(args[0])}, ...]" if args else "list"
    if origin is dict:
        return f"table of {_inner(args[1])}" if args else "table"
    if tp is Any:
        return "any"
    if isinstance(tp, type):
        if _is_schema(tp):
            return "table"
        return {"float": "float", "int": "int", "bool": "bool", "str": "string"}.get(tp.__name__, tp.__name__)
    return str(tp).replace("typing.", "")


def _inner(tp: Any) -> str:
    """A type inside a list or table, parenthesised when it is a choice (``table of (string or [string, ...])``)."""
    text = type_name(tp)
    return f"({text})" if " or " in text else text


def _number(value: float) -> str:
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e16:
        value = int(value)
    return f"{value:g}" if isinstance(value, float) else str(value)


def _bounds_text(bounds: Bounds, tp: Any) -> str:
    parts = []
    if bounds.ge is not None:
        parts.append(f">= {_number(bounds.ge)}")
    if bounds.gt is not None:
        parts.append(f"> {_number(bounds.gt)}")
    if bounds.le is not None:
        parts.append(f"<= {_number(bounds.le)}")
    if bounds.lt is not None:
        parts.append(f"< {_number(bounds.lt)}")
    if bounds.min_length:
        parts.append(f"at least {bounds.min_length} long")
    text = ", ".join(parts)
    if text and typing.get_origin(_bare(tp)) is tuple:
        text = "each " + text
    return text


def _bare(tp: Any) -> Any:
    """``tp`` without ``Annotated`` and ``| None``."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin is Annotated:
        return _bare(args[0])
    if origin in (typing.Union, types.UnionType):
        rest = [a for a in args if a is not type(None)]
        return _bare(rest[0]) if len(rest) == 1 else tp
    return tp


def _meaning(description: str, tp: Any, note: str) -> str:
    """What the schema says of a key: its description, else the class docstring's ``Attributes:`` entry, else
    the unit its type carries."""
    text = description or note
    if not text:
        text = next((b.description for b in _annotated_bounds(tp) if b.description), "")
    return markdown(text)


def markdown(text: str) -> str:
    """Docstring markup (reStructuredText roles, double backticks) as Markdown, on one line."""
    text = re.sub(r":(?:mod|class|func|meth|attr):`~?([^`]+)`", r"`\1`", text)
    return " ".join(text.replace("``", "`").split())


def _attribute_notes(schema: type) -> dict[str, str]:
    """``Attributes:`` entries of the docstrings of ``schema`` and its bases (Google style), key -> text."""
    notes: dict[str, str] = {}
    for owner in reversed(schema.__mro__):
        doc = inspect.getdoc(owner) if owner.__dict__.get("__doc__") else None
        if not doc or "Attributes:" not in doc:
            continue
        block = doc.split("Attributes:", 1)[1]
        current = None
        for line in block.splitlines():
            match = re.match(r"^    (\w+)(?: \([^)]*\))?: (.*)$", line)
            if match:
                current = match[1]
                notes[current] = match[2].strip()
            elif current and line.startswith("        "):
                notes[current] += " " + line.strip()
            elif line.strip() and not line.startswith(" "):
                break
    return notes


def _toml(value: Any) -> str:
    """A default as TOML would spell it."""
    if value is None:
        return "(none)"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float):
        if math.isfinite(value) and abs(value) >= FLOAT_LIMIT:
            return f"{value:g}"
        return f"{value:.6g}"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}" if value else "{}"
    if hasattr(value, "model_dump"):
        return _toml(value.model_dump())
    return str(value)


def _summary(cls: type) -> str:
    """The first paragraph of a class's docstring, on one line."""
    doc = inspect.getdoc(cls) if cls.__dict__.get("__doc__") else ""
    return markdown((doc or "").split("\n\n", 1)[0])


# ----------------------------------------------------------------- what the page covers
def core_sections() -> list[tuple[str, type, str]]:
    """``(heading, schema, note)`` of every core section, in the order a config is usually written."""
    import robokit.config as config
    from robokit.gym.spec import EnvSpec

    return [
        ("`[world]`", config.WorldConfig, ""),
        ("`[regions.NAME]`", config.RegionConfig, "regions"),
        ("`[bodies.NAME]`, `[robots.NAME]`", config.BodyConfig, "bodies"),
        ("`[[events]]`", config.EventConfig, ""),
        ("`[report]`", config.ReportConfig, "report"),
        ("`[record]`", config.RecordConfig, ""),
        ("`[gui]`", config.GuiConfig, ""),
        ("`[env]`", EnvSpec, "env"),
    ]


def builtin_types() -> dict[str, list[Any]]:
    """Every plugin type robokit itself ships, by kind, sorted by name."""
    from robokit.plugin_api.plugins import load_plugins
    from robokit.process.quiet import quiet_stdout

    with quiet_stdout():  # pybullet's build banner
        plugins = load_plugins(lazy=False)
    found: dict[str, list[Any]] = {kind: [] for kind in KINDS}
    for ptype in plugins.all_types():
        if ptype.distribution == "robokit" and ptype.kind in found:
            found[ptype.kind].append(ptype)
    return {kind: sorted(types_, key=lambda t: t.name) for kind, types_ in found.items()}


# ----------------------------------------------------------------- the page (its prose: config_reference_text)
def _cell(text: str) -> str:
    """Text for a table cell: pipes escaped, ``<placeholders>`` kept visible (not taken for HTML)."""
    return re.sub(r"<(?=[A-Za-z/!_])", "&lt;", text.replace("|", "\\|"))


def _table(schema: type, t: dict[str, str], owner: str, seen: set[type]) -> list[str]:
    keys = keys_of(schema)
    lines = [t["header"]]
    for k in keys:
        default = k.default
        if k.nested is not None and default.startswith("{") and len(default) > 40:
            default = t["below"]
        cells = (_words(k.type_text, t), _words(default, t), _words(k.bounds, t), k.meaning)
        lines.append(f"| `{k.name}` | " + " | ".join(_cell(c) for c in cells) + " |")
    for k in keys:
        if k.nested is not None and k.nested not in seen:
            seen.add(k.nested)
            lines += ["", t["nested"].format(owner=owner, key=_path(k)), "", *_table(k.nested, t, owner, seen)]
    return lines


def _words(text: str, t: dict[str, str]) -> str:
    """The page's own words in a type, default or bounds cell (``(none)``, ``or``, ``each``...) in its language."""
    for english, word in WORDS.get(t["lang"], ()):
        text = re.sub(english, word, text)
    return text




def _path(key: Key) -> str:
    """How a nested table is written: ``bins.NAME`` (a table of tables), ``script[i]`` (a list), ``mount``."""
    if key.type_text.startswith("table of"):
        return f"{key.name}.NAME"
    if key.type_text.startswith("["):
        return f"{key.name}[i]"
    return key.name


def render(lang: str) -> str:
    """The whole page in ``lang`` (``en`` or ``ko``)."""
    t = TEXT[lang]
    out = [t["title"], "", t["other"], "", t["generated"], "", t["rules_title"], "", t["rules"], "", t["core"]]
    for heading, schema, note in core_sections():
        out += ["", f"### {heading}", "", _cell(_summary(schema))]
        if note:
            out += ["", t[note]]
        out += ["", *_table(schema, t, heading, set())]
    out += ["", t["components"], "", t["kinds"], "", t["common"]]
    for kind, found in builtin_types().items():
        out += ["", t[kind]]
        for ptype in found:
            out += ["", f"### `{ptype.name}`", ""]
            cls_doc = _summary(ptype.cls)
            if cls_doc:
                out += [_cell(cls_doc), ""]
            out.append(f"{t['from']}: `{ptype.cls.__module__}`")
            out.append("")
            if ptype.schema is None or not keys_of(ptype.schema):
                rate = t["rate"] if kind in ("sensor", "actuator", "behaviour") else ""
                out.append(t["no_keys"].format(rate=rate))
                said = _summary(ptype.schema) if ptype.schema is not None else ""
                if said:  # e.g. a sequence's steps, tables the core reads
                    out += ["", _cell(said)]
            else:
                out += _table(ptype.schema, t, f"`{ptype.name}`", set())
    return "\n".join(out) + "\n"


def update(check: bool) -> list[Path]:
    """Write (or, with ``check``, compare) both pages; return the ones that were stale."""
    stale = []
    for lang, path in PAGES.items():
        text = render(lang)
        current = path.read_text(encoding="utf-8") if path.is_file() else ""
        if current != text:
            stale.append(path)
            if not check:
                path.write_text(text, encoding="utf-8")
    return stale


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m robokit.checks.config_reference",
                                     description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare only; exit 1 if a page is stale")
    args = parser.parse_args(argv)
    stale = update(args.check)
    for path in stale:
        print(("stale: " if args.check else "updated: ") + str(path.relative_to(ROOT)))
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
