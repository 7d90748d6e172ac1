"""Fixtures of the course server tests (a pytest plugin: ``pytest_plugins = ["course_fixtures"]``)."""

from __future__ import annotations

from typing import Any

import pytest
from course_helpers import PASSWORD, Course


@pytest.fixture
def course(db: Any, settings: Any) -> Course:
    """A teacher, a class that accepts posts without a token, two students with tokens, an official token."""
    settings.PASSWORD_HASHERS = ["django.contrib.auth.hashers.MD5PasswordHasher"]  # tests only: PBKDF2 is slow
    from django.contrib.auth import get_user_model

    from robokit.server import tokens
    from robokit.server.models import Classroom, Student

    teacher = get_user_model().objects.create_user("teacher", password=PASSWORD, is_staff=True)
    room = Classroom.objects.create(name="1반", owner=teacher, allow_unverified=True)
    kim = Student.objects.create(classroom=room, name="김민준")
    lee = Student.objects.create(classroom=room, name="<script>alert('x')</script>")
    return Course(teacher, room, kim, lee, tokens.issue_student_token(kim), tokens.issue_student_token(lee),
                  tokens.issue_teacher_token(room, teacher))
