"""``robokit manage create_class NAME --teacher USER [--allow-unverified]``."""

from __future__ import annotations

from typing import Any

from django.contrib.auth import get_user_model
from django.core.management.base import BaseCommand, CommandError, CommandParser

from robokit.server.models import Classroom


class Command(BaseCommand):
    help = "Create a class (or change whether it accepts posts without a token)."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("name")
        parser.add_argument("--teacher", required=True, help="the teacher's user name")
        group = parser.add_mutually_exclusive_group()
        group.add_argument("--allow-unverified", action="store_true",
                           help="accept posts without a token (as lesson 08's code sends them), marked unverified")
        group.add_argument("--tokens-only", action="store_true", help="refuse posts without a token (default)")

    def handle(self, *args: Any, **opts: Any) -> None:
        teacher = get_user_model().objects.filter(username=opts["teacher"]).first()
        if teacher is None:
            raise CommandError(f"no teacher {opts['teacher']!r}: create one with `robokit serve --create-teacher NAME`")
        room, created = Classroom.objects.get_or_create(name=opts["name"], defaults={"owner": teacher})
        if opts["allow_unverified"] or opts["tokens_only"] or created:
            room.allow_unverified = bool(opts["allow_unverified"])
            room.save(update_fields=["allow_unverified"])
        state = "accepts posts without a token" if room.allow_unverified else "needs a token"
        self.stdout.write(f"class {room.name!r} {'created' if created else 'exists'} (id {room.pk}); {state}")
