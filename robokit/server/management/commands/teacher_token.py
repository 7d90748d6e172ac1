"""``robokit manage teacher_token CLASS --teacher USER``: a token for official runs, printed once.

Results posted with it (e.g. by ``robokit sweep --report-url``) are marked official and ranked separately.
"""

from __future__ import annotations

from typing import Any

from django.contrib.auth import get_user_model
from django.core.management.base import BaseCommand, CommandError, CommandParser

from robokit.server import tokens
from robokit.server.management.commands._common import classroom


class Command(BaseCommand):
    help = "Issue a teacher token for official runs in a class and print it once."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("classroom")
        parser.add_argument("--teacher", required=True)

    def handle(self, *args: Any, **opts: Any) -> None:
        room = classroom(opts["classroom"])
        teacher = get_user_model().objects.filter(username=opts["teacher"]).first()
        if teacher is None:
            raise CommandError(f"no teacher {opts['teacher']!r}")
        if not (teacher.is_superuser or room.owner_id == teacher.pk):
            raise CommandError(f"{teacher.username!r} does not teach {room.name!r}")
        self.stdout.write(f"official\t{tokens.issue_teacher_token(room, teacher)}")
