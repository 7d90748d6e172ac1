"""Helpers shared by the course management commands."""

from __future__ import annotations

from django.core.management.base import CommandError

from robokit.server.models import Classroom, Student


def classroom(name: str) -> Classroom:
    """A class by name (or by id)."""
    found = Classroom.objects.filter(name=name).first()
    if found is None and name.isdigit():
        found = Classroom.objects.filter(pk=int(name)).first()
    if found is None:
        known = ", ".join(repr(c.name) for c in Classroom.objects.all()[:20]) or "none yet"
        raise CommandError(f"no class {name!r} (classes: {known})")
    return found


def student(room: Classroom, name: str) -> Student:
    found = room.students.filter(name=name).first()
    if found is None:
        raise CommandError(f"no student {name!r} in class {room.name!r}")
    return found
