"""The config reference (docs/config-reference.md and .ko.md) is generated from the schemas and cannot go stale:
regenerated here, compared with the committed pages; every core section key and every built-in type's key is on
it, with its default; the naming rule for ``count`` is stated; the README links both pages."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from robokit.checks import config_reference as ref

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def pages() -> dict[str, str]:
    return {lang: ref.render(lang) for lang in ref.PAGES}


def test_committed_pages_are_what_the_schemas_give(pages: dict[str, str]) -> None:
    for lang, path in ref.PAGES.items():
        assert path.read_text(encoding="utf-8") == pages[lang], (
            f"{path.relative_to(ROOT)} is stale: run python -m robokit.checks.config_reference")


def _rows(page: str, heading: str) -> dict[str, list[str]]:
    """The key rows of the table under ``### heading`` (up to the next heading), key -> cells."""
    start = page.index(f"### {heading}\n")
    end = page.find("\n### ", start + 1)
    block = page[start:end if end > 0 else len(page)]
    rows = {}
    for line in block.splitlines():
        match = re.match(r"^\| `(\w+)` \|(.*)\|$", line)
        if match and match[1] not in rows:
            rows[match[1]] = [c.strip() for c in match[2].split(" | ")]
    return rows


def test_every_core_key_is_listed_with_its_default(pages: dict[str, str]) -> None:
    import robokit.config as config

    for heading, schema in (("`[world]`", config.WorldConfig), ("`[regions.NAME]`", config.RegionConfig),
                            ("`[bodies.NAME]`, `[robots.NAME]`", config.BodyConfig),
                            ("`[[events]]`", config.EventConfig), ("`[record]`", config.RecordConfig),
                            ("`[gui]`", config.GuiConfig), ("`[report]`", config.ReportConfig)):
        rows = _rows(pages["en"], heading)
        assert set(rows) >= set(schema._fields), heading
    world = _rows(pages["en"], "`[world]`")
    assert world["max_time"][:3] == ["float", "60", "> 0, <= 1000000"]
    assert world["gravity"][1] == "[0, 0, -9.81]"
    bodies = _rows(pages["en"], "`[bodies.NAME]`, `[robots.NAME]`")
    assert bodies["mass"][1] == "1" and "kg" in bodies["mass"][3]
    assert bodies["rgba"][2] == "each >= 0, <= 1"
    assert bodies["count"][1] == "1" and "NAME_0" in bodies["count"][3]
    assert bodies["position"][3] == "metres, world frame"
    mount = pages["en"].split("`mount` is a table with these keys:", 1)[1]
    assert "| `position` | [float, float, float] | [0, 0, 0] | each >= -10000, <= 10000 | metres, in that link's " \
           "frame |" in mount.split("\n### ", 1)[0]


def test_every_builtin_plugin_type_and_key_is_listed(pages: dict[str, str]) -> None:
    from robokit.plugin_api.plugins import load_plugins

    plugins = load_plugins(lazy=False)
    builtin = [t for t in plugins.all_types() if t.distribution == "robokit"]
    assert len(builtin) >= 25
    for ptype in builtin:
        rows = _rows(pages["en"], f"`{ptype.name}`")
        fields = getattr(ptype.schema, "model_fields", None) or getattr(ptype.schema, "_fields", {})
        assert set(rows) >= set(fields), ptype.name
    lidar = _rows(pages["en"], "`lidar`")
    assert lidar["rays"][:3] == ["int", "360", ">= 1, <= 16384"] and lidar["range_max"][3] == "Longest range, m."


def test_naming_rules_and_both_languages(pages: dict[str, str]) -> None:
    assert "`count = 1` (the default) is one body named `red`" in pages["en"]
    assert "`red_0`, `red_1`" in pages["en"]
    ko = pages["ko"]
    assert ko.startswith("# 설정 파일 참고서") and "`count = 1`(기본값)이면 물체 하나, 이름은 `red`" in ko
    assert "| 키 | 타입 | 기본값 | 범위 | 설명 |" in ko and "| key |" not in ko
    # the same keys in both languages, row for row
    assert [line.split(" | ")[0] for line in pages["en"].splitlines() if line.startswith("| `")] == \
           [line.split(" | ")[0] for line in ko.splitlines() if line.startswith("| `")]


def test_the_readme_links_both_pages() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "(docs/config-reference.md)" in readme and "(docs/config-reference.ko.md)" in readme
