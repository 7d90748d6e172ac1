"""What a submission may change, over generated edits of the official config and generated allowed keys
(docs/server.md, "Create an assignment", "Students submit" and "Files a submission may name").

A student may change only the keys the assignment allows (``*`` matching anything: ``bodies.box.*``); ``world.seed``
is ignored; a removed key is a changed key; a list of tables is compared whole. A config that changes anything else
is refused before anything is stored, 400 naming the first such key in the file's order; a model path that leaves
the submission (``..``, an absolute path) is refused naming its key even where the key may change; otherwise the
submission is stored.

The expected answer is worked out here: the edits applied to the parsed official tree, written back as TOML by a
plain writer, the changed keys listed by walking both trees in the file's order, and a pattern matched by hand
(the key itself, or everything under ``prefix.*``).
"""

from __future__ import annotations

import copy
import json
from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=14, deadline=None, derandomize=True, database=None,
                 phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
REMOVE = object()
EDITS = {  # key -> a value robokit's validation accepts (or REMOVE: the key taken out), or a path that leaves
    "world.seed": 11, "world.max_time": 5.0, "behaviour.duration": 0.3, "bodies.box.mass": 2.0,
    "bodies.box.position": [0, -1.0, 1.2], "bodies.sphere.restitution": 0.4, "bodies.cylinder.rgba": [0.1, 0.1, 0.1, 1],
    "regions.scatter.z": 1.4, "bodies.box.lateral_friction": REMOVE, "bodies.sphere.rolling_friction": REMOVE,
    "events": [{"at": 1.0, "type": "force", "body": "box", "force": [30, 0, 0], "duration": 0.05}],
    "bodies.plane.urdf": "../../robokit-server/secret_key", "bodies.plane.restitution": 0.8}
PATTERNS = ("world.max_time", "behaviour.duration", "bodies.box.*", "bodies.*", "events", "world.*",
            "regions.scatter.z", "bodies.sphere.restitution", "bodies.plane.urdf")


def leaves(tree: dict[str, Any], prefix: str = "") -> Iterator[tuple[str, Any]]:
    for key, value in tree.items():
        path = f"{prefix}.{key}" if prefix else key
        if isinstance(value, dict):
            yield from leaves(value, path)
        else:
            yield path, value


def toml(tree: dict[str, Any]) -> str:
    """A plain TOML writer for the drop test's tree: tables, arrays of tables, scalars and lists."""
    lines: list[str] = []

    def table(node: dict[str, Any], path: str) -> None:
        scalars = {k: v for k, v in node.items() if not isinstance(v, dict) and not (
            isinstance(v, list) and v and isinstance(v[0], dict))}
        if path and scalars:
            lines.append(f"[{path}]")
        lines.extend(f"{k} = {json.dumps(v)}" for k, v in scalars.items())
        for k, v in node.items():
            if isinstance(v, dict):
                table(v, f"{path}.{k}" if path else k)
        for k, v in node.items():
            if isinstance(v, list) and v and isinstance(v[0], dict):
                for item in v:
                    lines.append(f"[[{path + '.' if path else ''}{k}]]")
                    lines.extend(f"{ik} = {json.dumps(iv)}" for ik, iv in item.items())

    table(tree, "")
    return "\n".join(lines) + "\n"


def allowed(key: str, patterns: list[str]) -> bool:
    return any(p == key or (p.endswith(".*") and key.startswith(p[:-1])) for p in patterns)


@pytest.fixture
def queued(settings: Any) -> None:
    settings.QUEUE_SYNC = False  # stored and queued; nothing is evaluated here


@PROPS
@given(edits=st.lists(st.sampled_from(sorted(EDITS)), unique=True, max_size=4),
       patterns=st.lists(st.sampled_from(PATTERNS), unique=True, max_size=3))
def test_a_submission_changes_only_what_the_assignment_allows(client: Any, course: Any, queued: None,
                                                              edits: list[str], patterns: list[str]) -> None:
    import tomllib
    from course_work import OFFICIAL, make_assignment

    from robokit.server.models import Assignment, Project, Submission

    Assignment.objects.all().delete()
    Project.objects.all().delete()
    a = make_assignment(course.room, allowed_keys=patterns, max_waiting=0, max_per_day=0)
    official = tomllib.loads(OFFICIAL)
    mine = copy.deepcopy(official)
    for key in edits:
        *parents, last = key.split(".")
        node = mine
        for p in parents:
            node = node[p]
        if EDITS[key] is REMOVE:
            del node[last]
        else:
            node[last] = EDITS[key]
    text = toml(mine)
    assert tomllib.loads(text) == mine  # the writer wrote what was meant

    before, after = dict(leaves(official)), dict(leaves(mine))
    changed = [k for k in before if before[k] != after.get(k, REMOVE)] + [k for k in after if k not in before]
    assert sorted(changed) == sorted(edits)
    refused = [k for k in changed if k != "world.seed" and not allowed(k, patterns)]
    got = client.post(f"/api/robotics/assignments/{a.name}/submissions/", data=json.dumps({"config": text}),
                      content_type="application/json", HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
    if refused:
        assert (got.status_code, got.json()["field"]) == (400, refused[0]), got.content
        assert "students may not change this key" in got.json()["error"]
    elif "bodies.plane.urdf" in edits:
        assert (got.status_code, got.json()["field"]) == (400, "bodies.plane.urdf"), got.content
        assert "leaves the submission" in got.json()["error"]
    else:
        assert got.status_code == 201, got.content
        assert Submission.objects.get(pk=got.json()["id"]).config_text == text
        return
    assert not Submission.objects.exists()
