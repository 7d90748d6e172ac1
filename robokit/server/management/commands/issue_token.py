"""``robokit manage issue_token CLASS STUDENT``: a new token (the old one stops working); printed once."""

from __future__ import annotations

from typing import Any

from django.core.management.base import BaseCommand, CommandParser

from robokit.server import tokens
from robokit.server.management.commands._common import classroom, student


class Command(BaseCommand):
    help = "Issue a new token for a student (revokes their old one) and print it once."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("classroom")
        parser.add_argument("student")

    def handle(self, *args: Any, **opts: Any) -> None:
        who = student(classroom(opts["classroom"]), opts["student"])
        self.stdout.write(f"{who.name}\t{tokens.issue_student_token(who)}")
