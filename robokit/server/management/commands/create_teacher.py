"""``robokit manage create_teacher NAME``: a teacher login (staff, may use the admin for the course's models).

The password comes from the environment variable ``ROBOKIT_TEACHER_PASSWORD`` or, when it is unset, from a
prompt (asked twice). It is never taken from the command line, where other users could see it.
"""

from __future__ import annotations

import getpass
import os
from typing import Any

from django.contrib.auth import get_user_model
from django.contrib.auth.models import Permission
from django.contrib.auth.password_validation import validate_password
from django.core.exceptions import ValidationError
from django.core.management.base import BaseCommand, CommandError, CommandParser

PASSWORD_ENV = "ROBOKIT_TEACHER_PASSWORD"


class Command(BaseCommand):
    help = "Create (or reset the password of) a teacher login."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("name")
        parser.add_argument("--superuser", action="store_true", help="may see and change every class")

    def handle(self, *args: Any, **opts: Any) -> None:
        password = os.environ.get(PASSWORD_ENV) or self._prompt()
        User = get_user_model()
        user = User.objects.filter(username=opts["name"]).first() or User(username=opts["name"])
        try:
            validate_password(password, user)
        except ValidationError as exc:
            raise CommandError("password refused: " + " ".join(exc.messages)) from None
        created = user.pk is None
        user.is_staff = True
        user.is_superuser = user.is_superuser or opts["superuser"]
        user.set_password(password)
        user.save()
        user.user_permissions.add(*Permission.objects.filter(content_type__app_label="course"))
        self.stdout.write(f"teacher {opts['name']!r} {'created' if created else 'updated'}: log in at /accounts/login/")

    def _prompt(self) -> str:
        try:
            first = getpass.getpass("Password: ")
            second = getpass.getpass("Password (again): ")
        except (EOFError, KeyboardInterrupt):
            raise CommandError(f"no password: set {PASSWORD_ENV} or run in a terminal") from None
        if first != second:
            raise CommandError("the two passwords differ")
        return first
