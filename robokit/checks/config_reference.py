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
            return f"[{type_name(args[0])}, ...]"
        return "[" + ", ".join(type_name(a) for a in args) + "]"
    if origin in (list, set, frozenset):
        return f"[{type_name(args[0])}, ...]" if args else "list"
    if origin is dict:
        return f"table of {type_name(args[1])}" if args else "table"
    if tp is Any:
        return "any"
    if isinstance(tp, type):
        if _is_schema(tp):
            return "table"
        return {"float": "float", "int": "int", "bool": "bool", "str": "string"}.get(tp.__name__, tp.__name__)
    return str(tp).replace("typing.", "")


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


# ----------------------------------------------------------------- the page
TEXT: dict[str, dict[str, str]] = {
    "en": {
        "lang": "en",
        "title": "# Config reference",
        "other": "[한국어](config-reference.ko.md) · [README](../README.md)",
        "generated": ("Generated from the schemas by `python -m robokit.checks.config_reference`; a test fails when "
                      "this page and the schemas differ, so what you read here is what `robokit validate` checks."),
        "rules_title": "## Rules for every key",
        "rules": """\
- **Units.** Lengths and positions in metres, angles in degrees where the key ends in `_deg` (else radians, as
  the description says), times in seconds of **sim time**, rates in Hz of sim time, forces in newtons, masses in
  kilograms. Positions are in the world frame (x forward, y left, z up) unless the description names another.
- **Colours** are `[red, green, blue, alpha]` floats from 0 to 1 (`[0.9, 0.1, 0.1, 1]`); 0-255 values are refused
  with the 0-1 equivalent.
- **Numbers.** Every float is finite and within ±1e9 unless its bounds say otherwise; an integer is accepted where
  a float is expected, `true` is not a number and `1` is not a boolean. A list has exactly the length shown.
- **Unknown keys are errors** (with a "did you mean"); so is a missing required key. Every error is one line
  naming the file and the key path: `robokit validate CONFIG` checks a config without running it.
- **Body names.** `[bodies.red]` with `count = 1` (the default) is one body named `red`; with `count = N` the
  copies are `red_0`, `red_1` … `red_{N-1}` (scattered in the body's `region`). An SDF or MJCF file holding
  several models gives `NAME`, `NAME_1`, `NAME_2` … Sensors, actuators and behaviours name bodies, joints and
  links by these names; an unknown name fails with the list of valid ones.
- **Model files** (`urdf`, `sdf`, `mjcf`) are paths relative to the config file, robokit's bundled robots, or
  `pybullet_data` names (`"franka_panda/panda.urdf"`). The key must match the file: `urdf = "x.sdf"` is an error
  naming `sdf =`.
- **Plugin sections** (`[sensors.NAME]`, `[actuators.NAME]`, `[behaviour]`, `[monitors.NAME]`,
  `[report.NAME]`, `[env.task]`) take `type` (a registered type name; `DIST:type` when two distributions register
  the same name) and, except `[env.task]` and reporters, `rate_hz`: how often it runs, in Hz of sim time (default:
  every physics tick); it must divide the physics rate (`1 / world.time_step`, 240 Hz by default). The other keys
  are the type's own, listed below; `robokit plugins` lists every installed type.""",
        "core": "## Core sections",
        "components": "## Sections that name a plugin type",
        "kinds": ("`[sensors.NAME]` takes a sensor type, `[actuators.NAME]` an actuator type, `[behaviour]` and "
                  "`[monitors.NAME]` a behaviour type, `[report.NAME]` a reporter type (`local` is always on "
                  "unless `[report] keep_local = false`), `[env.task]` a task type. Common keys:"),
        "common": "| key | type | default | bounds | meaning |\n|---|---|---|---|---|\n"
                  "| `type` | string | (required) | | the type's name (`dist:type` when names clash) |\n"
                  "| `rate_hz` | float (optional) | every tick | > 0, divides the physics rate | Hz of sim time |",
        "header": "| key | type | default | bounds | meaning |\n|---|---|---|---|---|",
        "sensor": "## Sensor types (`[sensors.NAME]`)",
        "actuator": "## Actuator types (`[actuators.NAME]`)",
        "behaviour": "## Behaviour types (`[behaviour]`, `[monitors.NAME]`)",
        "reporter": "## Reporter types (`[report.NAME]`)",
        "task": "## Task types (`[env.task]`, see [gym.md](gym.md))",
        "no_keys": "No keys besides `type`{rate}.",
        "rate": " and `rate_hz`",
        "nested": "{owner}: `{key}` is a table with these keys:",
        "regions": "Bodies with `region = NAME` are placed at seeded random spots inside it.",
        "bodies": ("Exactly one of `shape`, `urdf`, `sdf`, `mjcf`; a pose from `position` or `region` (or "
                   "`mount`). `count = N` makes N copies named `NAME_0` … `NAME_{N-1}` (see the rules above)."),
        "report": "Besides these keys, one sub-table per reporter: `[report.local]`, `[report.http]` (below).",
        "env": "Read by `robokit.gym.make(config)`; `robokit run` ignores it. See [gym.md](gym.md).",
        "from": "from",
        "below": "(see below)",
    },
    "ko": {
        "lang": "ko",
        "title": "# 설정 파일 참고서",
        "other": "[English](config-reference.md) · [README](../README.md)",
        "generated": ("`python -m robokit.checks.config_reference`가 스키마에서 만든 페이지입니다. "
                      "이 페이지와 스키마가 다르면 테스트가 실패하므로, 여기 적힌 내용이 곧 "
                      "`robokit validate`가 검사하는 내용입니다. 키 이름과 '설명' 열은 코드의 스키마에 적힌 "
                      "영어 그대로입니다."),
        "rules_title": "## 모든 키에 통하는 규칙",
        "rules": """\
- **단위.** 길이와 위치는 미터, 키 이름이 `_deg`로 끝나면 각도는 도(그 밖에는 설명에 적힌 대로 라디안), 시간은
  **시뮬레이션 시간**의 초, 주기는 시뮬레이션 시간 기준 Hz, 힘은 뉴턴, 질량은 킬로그램입니다. 설명에 다른 좌표계가
  없으면 위치는 월드 좌표계(x 앞, y 왼쪽, z 위)입니다.
- **색**은 0에서 1 사이 실수 `[빨강, 초록, 파랑, 알파]`입니다(`[0.9, 0.1, 0.1, 1]`). 0-255 값은 0-1로 바꾼 값을
  알려 주며 거부됩니다.
- **숫자.** 범위가 따로 없으면 모든 실수는 유한하고 ±1e9 안이어야 합니다. 실수 자리에 정수를 써도 되지만 `true`는
  숫자가 아니고 `1`은 불리언이 아닙니다. 목록은 표에 적힌 길이와 정확히 같아야 합니다.
- **모르는 키는 오류입니다**("did you mean" 제안과 함께). 필수 키가 빠져도 오류입니다. 오류는 언제나 파일과 키
  경로를 적은 한 줄이며, `robokit validate CONFIG`로 실행하지 않고 설정만 검사할 수 있습니다.
- **물체 이름.** `[bodies.red]`에 `count = 1`(기본값)이면 물체 하나, 이름은 `red`입니다. `count = N`이면 복사본의
  이름은 `red_0`, `red_1` … `red_{N-1}`이고 그 물체의 `region` 안에 흩어 놓입니다. 모델이 여러 개 든 SDF나 MJCF
  파일은 `NAME`, `NAME_1`, `NAME_2` …가 됩니다. 센서, 액추에이터, 행동은 물체·관절·링크를 이 이름으로 부르며,
  모르는 이름은 올바른 이름 목록과 함께 실패합니다.
- **모델 파일**(`urdf`, `sdf`, `mjcf`)은 설정 파일 기준 상대 경로, robokit에 들어 있는 로봇, 또는 `pybullet_data`
  이름(`"franka_panda/panda.urdf"`)입니다. 키는 파일 종류와 맞아야 합니다: `urdf = "x.sdf"`는 `sdf =`를 알려 주는
  오류입니다.
- **플러그인 섹션**(`[sensors.NAME]`, `[actuators.NAME]`, `[behaviour]`, `[monitors.NAME]`, `[report.NAME]`,
  `[env.task]`)은 `type`(등록된 타입 이름, 두 배포판이 같은 이름을 등록하면 `DIST:type`)을 받고, `[env.task]`와
  리포터를 빼면 `rate_hz`(시뮬레이션 시간 기준 실행 주기 Hz, 기본값은 물리 스텝마다)도 받습니다. `rate_hz`는 물리
  주기(`1 / world.time_step`, 기본 240 Hz)를 나누어떨어지게 해야 합니다. 나머지 키는 아래에 적힌 타입별 키이며,
  설치된 모든 타입은 `robokit plugins`로 볼 수 있습니다.""",
        "core": "## 핵심 섹션",
        "components": "## 플러그인 타입을 고르는 섹션",
        "kinds": ("`[sensors.NAME]`은 센서 타입, `[actuators.NAME]`은 액추에이터 타입, `[behaviour]`와 "
                  "`[monitors.NAME]`은 행동 타입, `[report.NAME]`은 리포터 타입(`[report] keep_local = false`가 "
                  "아니면 `local`은 항상 켜짐), `[env.task]`는 태스크 타입을 받습니다. 공통 키:"),
        "common": "| 키 | 타입 | 기본값 | 범위 | 설명 |\n|---|---|---|---|---|\n"
                  "| `type` | string | (필수) | | 타입 이름 (이름이 겹치면 `dist:type`) |\n"
                  "| `rate_hz` | float (선택) | 매 틱 | > 0, 물리 주기를 나누어떨어지게 | 시뮬레이션 시간 기준 Hz |",
        "header": "| 키 | 타입 | 기본값 | 범위 | 설명 |\n|---|---|---|---|---|",
        "sensor": "## 센서 타입 (`[sensors.NAME]`)",
        "actuator": "## 액추에이터 타입 (`[actuators.NAME]`)",
        "behaviour": "## 행동 타입 (`[behaviour]`, `[monitors.NAME]`)",
        "reporter": "## 리포터 타입 (`[report.NAME]`)",
        "task": "## 태스크 타입 (`[env.task]`, [gym.md](gym.md) 참고)",
        "no_keys": "`type`{rate} 말고는 키가 없습니다.",
        "rate": "과 `rate_hz`",
        "nested": "{owner}: `{key}`는 다음 키를 가진 표입니다:",
        "regions": "`region = NAME`인 물체는 이 사각형 안의 시드에 따른 무작위 위치에 놓입니다.",
        "bodies": ("`shape`, `urdf`, `sdf`, `mjcf` 중 정확히 하나, 자세는 `position`이나 `region`(또는 `mount`)에서 "
                   "옵니다. `count = N`이면 `NAME_0` … `NAME_{N-1}`이라는 복사본 N개가 생깁니다(위 규칙 참고)."),
        "report": "이 키들 말고도 리포터마다 하위 표가 하나씩 있습니다: `[report.local]`, `[report.http]`(아래).",
        "env": "`robokit.gym.make(config)`가 읽고 `robokit run`은 무시합니다. [gym.md](gym.md)를 보세요.",
        "from": "출처",
        "below": "(아래 참고)",
    },
}


def _cell(text: str) -> str:
    """Text for a table cell: pipes escaped, ``<placeholders>`` kept visible (not taken for HTML)."""
    return re.sub(r"<(?=[A-Za-z/!_])", "&lt;", text.replace("|", "\\|"))


def _table(schema: type, t: dict[str, str], owner: str, seen: set[type]) -> list[str]:
    keys = keys_of(schema)
    lines = [t["header"]]
    for k in keys:
        default = "(필수)" if k.default == "(required)" and t is TEXT["ko"] else k.default
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


WORDS = {"ko": (
    (r"^\(none\)$", "(없음)"), (r" \(optional\)$", " (선택)"), (r"^each ", "각 항목 "), (r" or ", " 또는 "),
    (r"^table of (.*)$", r"\1의 표"), (r"at least (\d+) long", r"길이 \1 이상"),
)}


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
