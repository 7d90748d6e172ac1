"""What a plugin author reads is what the code has: every `JointInfo` field with its type (and `child_link` a
name, which `world.pose` does not take), every `sim.` member the example packages use, every `ScriptedRun` member
(and that `states` includes sub-machines' states, as it does)."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

from robokit.checks.scripted import ScriptedRun
from robokit.core.world import JointInfo
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
PLUGINS = (ROOT / "docs" / "plugins.md").read_text(encoding="utf-8")
BEHAVIOURS = (ROOT / "docs" / "behaviours.md").read_text(encoding="utf-8")


def _rows(text: str) -> list[list[str]]:
    return [[c.strip() for c in line.strip().strip("|").split("|")] for line in text.splitlines()
            if line.startswith("| `")]


def test_every_joint_info_field_is_documented_with_its_type() -> None:
    documented = {}
    for cells in _rows(PLUGINS):
        for name in re.findall(r"`(\w+)`", cells[0]):
            if len(cells) >= 3:
                documented[name] = cells[1]
    for field in dataclasses.fields(JointInfo):
        assert documented.get(field.name) == f"`{field.type}`", (field.name, documented.get(field.name))
    assert "`bool` (property)" == documented.get("movable")
    child = next(c for c in _rows(PLUGINS) if c[0] == "`child_link`")
    assert "**name**" in child[2] and "world.pose" in child[2]


def test_child_link_is_a_name_whose_index_is_the_joints_as_the_docs_say() -> None:
    config = {"bodies": {"arm": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}}}
    with make_sim(config) as sim:
        for info in sim.world.joints("arm"):
            assert isinstance(info.child_link, str)
            assert sim.world.link("arm", info.child_link) == info.index


def test_every_sim_member_the_example_packages_use_is_in_the_testing_table() -> None:
    used = {m for path in (ROOT / "examples").rglob("*.py")
            for m in re.findall(r"\bsim\.([a-z_]+)", path.read_text(encoding="utf-8"))}
    assert {"outcome", "behaviour"} <= used
    section = PLUGINS.split("## 10. Testing with `robokit.testing`")[1].split("\n## ")[0]
    missing = [m for m in sorted(used) if f"`sim.{m}" not in section]
    assert not missing, f"docs/plugins.md section 10 does not document sim.{missing}"


def test_every_scripted_run_member_is_in_the_member_table_and_states_says_sub_machines() -> None:
    members = {n for n in vars(ScriptedRun) if not n.startswith("_")}
    table = BEHAVIOURS.split("| `ScriptedRun(...)` argument |")[1].split("\n\n")[1]
    named = {n for cells in _rows(table) for n in re.findall(r"`(\w+)", cells[0])}
    assert members <= named, sorted(members - named)
    states = next(c for c in _rows(table) if c[0] == "`states`")
    assert "sub-machine" in states[1]
