"""``robokit manage revoke_token CLASS STUDENT``: the student's token stops working (401)."""

from __future__ import annotations

from typing import Any

from django.core.management.base import BaseCommand, CommandParser

from robokit.server import tokens
from robokit.server.management.commands._common import classroom, student


class Command(BaseCommand):
    help = "Revoke a student's token(s): posts with them are refused with 401."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("classroom")
        parser.add_argument("student")

    def handle(self, *args: Any, **opts: Any) -> None:
        who = student(classroom(opts["classroom"]), opts["student"])
        n = tokens.revoke_student_tokens(who)
        self.stdout.write(f"{who.name}: {n} token(s) revoked")
