"""Students' and teachers' tokens over generated sequences of the teacher's commands (docs/server.md, "A class, its
students, their tokens").

A token is printed once; only its SHA-256 is stored; a new token for a student revokes the old one; a revoked token's
posts get 401 ``revoked token``, an unknown one 401 ``unknown token``; a student's token posts as its student whatever
the payload says, a teacher's token posts official runs.

Each example runs a generated sequence of ``issue_token``, ``revoke_token`` and ``teacher_token`` (the management
commands the page gives, in this process) on two students, then posts a result with every token ever printed.
What each post must get is worked out here by replaying the sequence: a student's token works only if it is the
last one printed for that student and no revoke came after it; a teacher's token always works.
"""

from __future__ import annotations

import hashlib
import io
from typing import Any

from course_helpers import post
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=10, deadline=None, derandomize=True, database=None,
                 phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def manage(*argv: str) -> str:
    from django.core.management import call_command

    out = io.StringIO()
    call_command(*argv, stdout=out)
    return out.getvalue()


@PROPS
@given(st.lists(st.tuples(st.sampled_from(["issue_token", "revoke_token", "teacher_token"]), st.sampled_from([0, 1])),
                min_size=1, max_size=8))
def test_every_token_printed_works_exactly_while_the_commands_say(client: Any, course: Any,
                                                                   steps: list[tuple[str, int]]) -> None:
    from robokit.server.models import Result, Student, Token

    Result.objects.all().delete()
    Token.objects.all().delete()
    names = [course.kim.name, "=박지호"]
    Student.objects.get_or_create(classroom=course.room, name=names[1])
    printed: list[tuple[str, str | None]] = []  # (token, student name or None for a teacher's)
    live: dict[str, str] = {}  # student -> their working token
    for command, who in steps:
        if command == "issue_token":
            name, token = manage(command, course.room.name, names[who]).strip().split("\t")
            assert name == names[who] and token.startswith("rks_") and len(token) == 4 + 43  # 32 random bytes
            printed.append((token, names[who]))
            live[names[who]] = token
        elif command == "revoke_token":
            manage(command, course.room.name, names[who])
            live.pop(names[who], None)
        else:
            token = manage(command, course.room.name, "--teacher", "teacher").strip().split()[-1]
            assert token.startswith("rkt_") and len(token) == 4 + 43
            printed.append((token, None))

    stored = set(Token.objects.values_list("key_hash", flat=True))
    assert stored == {hashlib.sha256(t.encode()).hexdigest() for t, _ in printed}  # the hashes, nothing else
    for i, (token, owner) in enumerate(printed):
        answer = post(client, {"project": "A", "student": "누구", "run_id": f"run-{i}"}, token)
        if owner is None or live.get(owner) == token:
            assert answer.status_code == 201, (owner, answer.content)
            record = answer.json()
            assert (record["verified"], record["official"]) == (True, owner is None)
            assert record["student"] == (owner or "누구") and record["posted_student"] == "누구"
        else:
            assert answer.status_code == 401 and answer.json()["error"].startswith("revoked token"), answer.content
            assert not Result.objects.filter(run_id=f"run-{i}").exists()
    unknown = post(client, {"project": "A", "student": "누구"}, "rks_" + "A" * 43)
    assert unknown.status_code == 401 and unknown.json()["error"].startswith("unknown token")
