"""``robokit manage add_students CLASS NAME [NAME ...] [--file names.txt]``: students and their tokens.

Prints ``name<TAB>token`` for each new student, once: only the tokens' hashes are stored. A student who already
exists is left alone (use ``issue_token`` for a new token).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from django.core.management.base import BaseCommand, CommandError, CommandParser
from django.db import transaction

from robokit.server import tokens
from robokit.server.management.commands._common import classroom
from robokit.server.models import Student


class Command(BaseCommand):
    help = "Add students to a class and print each new student's token (shown once)."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("classroom")
        parser.add_argument("names", nargs="*")
        parser.add_argument("--file", help="a UTF-8 text file with one name a line")

    def handle(self, *args: Any, **opts: Any) -> None:
        room = classroom(opts["classroom"])
        names = list(opts["names"])
        if opts["file"]:
            try:
                names += Path(opts["file"]).read_text(encoding="utf-8-sig").splitlines()
            except (OSError, UnicodeDecodeError) as exc:
                raise CommandError(f"{opts['file']}: {exc}") from None
        names = [" ".join(n.split()) for n in names if n.strip()]
        if not names:
            raise CommandError("no names given")
        for name in names:
            if len(name) > 100:
                raise CommandError(f"name longer than 100 characters: {name[:40]!r}...")
        with transaction.atomic():
            for name in dict.fromkeys(names):
                student, created = Student.objects.get_or_create(classroom=room, name=name)
                if created:
                    self.stdout.write(f"{name}\t{tokens.issue_student_token(student)}")
                else:
                    self.stderr.write(f"{name}: already in {room.name!r}, token unchanged")
