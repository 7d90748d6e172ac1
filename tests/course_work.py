"""Helpers of the course-work tests (assignments, submissions): the official config and submitting."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
OFFICIAL = re.sub(r"duration = 5\.0", "duration = 0.5", (ROOT / "configs" / "drop_test.toml").read_text("utf-8"))
"""Lesson 01's drop test, watched for 0.5 sim s: it succeeds on every seed (a quick official trial)."""
ALLOWED = ["world.max_time", "behaviour.duration"]


def changed(text: str, **values: str) -> str:
    """The official config with ``key = value`` lines replaced (``max_time="0.2"`` sets ``max_time = 0.2``)."""
    for key, value in values.items():
        text, n = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value}", text, count=1)
        assert n == 1, key
    return text


def make_assignment(room: Any, name: str = "낙하 실험", seeds: tuple[int, ...] = (0, 1), **fields: Any) -> Any:
    from robokit.server.models import Assignment, Project

    project, _ = Project.objects.get_or_create(classroom=room, name=name)
    values = {"kind": "drop_test", "config_text": OFFICIAL, "allowed_keys": ALLOWED, "seeds": list(seeds),
              "trial_seconds": 60.0, "project": project, **fields}
    return Assignment.objects.create(classroom=room, name=name, **values)


def submit(client: Any, name: str, config: str, token: str | None) -> Any:
    headers = {"HTTP_AUTHORIZATION": f"Bearer {token}"} if token else {}
    return client.post(f"/api/robotics/assignments/{name}/submissions/", data=json.dumps({"config": config}),
                       content_type="application/json", **headers)
