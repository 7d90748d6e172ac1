"""Classes, students, tokens, projects, results and their artifacts.

A result belongs to a class and a project. ``verified`` means it was posted with a student's (or the teacher's)
token, so it counts for that token's owner whatever the payload's ``student`` says; ``official`` means a teacher's
token posted it (e.g. ``robokit sweep --report-url``). ``run_id`` is unique: a repeated ``Idempotency-Key`` or
``run_id`` can never make a second row, even when two requests race (the database refuses the second insert).
"""

from __future__ import annotations

from typing import Any

from django.conf import settings
from django.db import models
from django.db.models import Q


class Classroom(models.Model):
    """A class: its teacher, its students, and whether posts without a token are accepted."""

    name = models.CharField(max_length=100, unique=True)
    owner = models.ForeignKey(settings.AUTH_USER_MODEL, on_delete=models.PROTECT, related_name="classrooms")
    allow_unverified = models.BooleanField(
        default=False, help_text="accept posts without a token (as lesson 08's code sends them), marked unverified")
    created_at = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["name"]

    def __str__(self) -> str:
        return self.name


class Student(models.Model):
    classroom = models.ForeignKey(Classroom, on_delete=models.CASCADE, related_name="students")
    name = models.CharField(max_length=100)
    created_at = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["name"]
        constraints = [models.UniqueConstraint(fields=["classroom", "name"], name="student_name_unique_in_class")]

    def __str__(self) -> str:
        return f"{self.name} ({self.classroom})"


class Token(models.Model):
    """A bearer token, stored as its SHA-256 only (the token itself is shown once, when issued)."""

    STUDENT, TEACHER = "student", "teacher"
    kind = models.CharField(max_length=10, choices=[(STUDENT, "student"), (TEACHER, "teacher (official runs)")])
    key_hash = models.CharField(max_length=64, unique=True, editable=False)
    classroom = models.ForeignKey(Classroom, on_delete=models.CASCADE, related_name="tokens")
    student = models.ForeignKey(Student, on_delete=models.CASCADE, null=True, blank=True, related_name="tokens")
    teacher = models.ForeignKey(settings.AUTH_USER_MODEL, on_delete=models.CASCADE, null=True, blank=True,
                                related_name="course_tokens")
    created_at = models.DateTimeField(auto_now_add=True)
    revoked_at = models.DateTimeField(null=True, blank=True)
    last_used_at = models.DateTimeField(null=True, blank=True)

    class Meta:
        constraints = [models.CheckConstraint(
            condition=Q(kind="student", student__isnull=False) | Q(kind="teacher", teacher__isnull=False),
            name="token_has_owner")]

    @property
    def active(self) -> bool:
        return self.revoked_at is None

    @property
    def owner_name(self) -> str:
        return self.student.name if self.student is not None else str(self.teacher)

    def __str__(self) -> str:
        state = "active" if self.active else "revoked"
        return f"{self.kind} token of {self.owner_name} in {self.classroom} ({state})"


class Project(models.Model):
    """A class's project (lesson 08's A or B, or any name a payload brings), with the figures that rank its runs.

    A project belongs to one class: two classes posting project "A" have two rows, each with its own ranking, so a
    teacher's change reorders only their own class's leaderboard.
    """

    classroom = models.ForeignKey(Classroom, on_delete=models.CASCADE, related_name="projects")
    name = models.CharField(max_length=100)
    ranking = models.CharField(
        max_length=300, blank=True,
        help_text="figures that rank runs, most important first, comma-separated; '-' in front = higher is better "
                  "(e.g. -sorted_total,failures,total_time)")
    created_at = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["name", "classroom__name"]
        constraints = [models.UniqueConstraint(fields=["classroom", "name"], name="project_name_unique_in_class")]

    def __str__(self) -> str:
        return self.name

    def ranking_keys(self) -> list[tuple[str, bool]]:
        """``[(figure, higher_is_better), ...]`` from :attr:`ranking`."""
        out = []
        for part in self.ranking.split(","):
            part = part.strip()
            if part:
                out.append((part.lstrip("-+"), part.startswith("-")))
        return out


class Result(models.Model):
    run_id = models.CharField(max_length=64, unique=True)
    classroom = models.ForeignKey(Classroom, on_delete=models.CASCADE, related_name="results")
    # RESTRICT: a project with results cannot be deleted on its own, but deleting its class removes both.
    project = models.ForeignKey(Project, on_delete=models.RESTRICT, related_name="results")
    student = models.ForeignKey(Student, on_delete=models.SET_NULL, null=True, blank=True, related_name="results")
    student_name = models.CharField(max_length=100, help_text="who the run counts for (the token's owner if any)")
    posted_student = models.CharField(max_length=100, blank=True, help_text="the payload's own 'student'")
    token = models.ForeignKey(Token, on_delete=models.SET_NULL, null=True, blank=True, related_name="results")
    verified = models.BooleanField(default=False)
    official = models.BooleanField(default=False)
    outcome = models.CharField(max_length=20, blank=True)
    reason = models.TextField(blank=True)
    behaviour = models.CharField(max_length=100, blank=True)
    config = models.CharField(max_length=300, blank=True)
    seed = models.BigIntegerField(null=True, blank=True)
    sim_time = models.FloatField(null=True, blank=True)
    wall_time = models.FloatField(null=True, blank=True)
    started_at = models.CharField(max_length=40, blank=True)
    red_sorted = models.IntegerField(null=True, blank=True)
    blue_sorted = models.IntegerField(null=True, blank=True)
    failures = models.IntegerField(null=True, blank=True)
    total_time = models.FloatField(null=True, blank=True)
    figures = models.JSONField(default=dict, blank=True)
    payload = models.JSONField(default=dict)
    received_at = models.DateTimeField(auto_now_add=True, db_index=True)
    submission = models.ForeignKey("course.Submission", on_delete=models.CASCADE, null=True, blank=True,
                                   related_name="results", help_text="the submission this official trial evaluated")
    excluded = models.BooleanField(default=False, help_text="left out of every board (see the moderation log)")

    class Meta:
        ordering = ["-received_at", "-id"]
        indexes = [models.Index(fields=["classroom", "project", "received_at"])]

    def __str__(self) -> str:
        return f"{self.student_name} / {self.project} / {self.run_id}"

    def to_dict(self) -> dict[str, Any]:
        """The stored record as the API answers it."""
        return {
            "id": self.pk, "run_id": self.run_id, "classroom": self.classroom.name, "project": self.project.name,
            "student": self.student_name, "posted_student": self.posted_student, "verified": self.verified,
            "official": self.official, "outcome": self.outcome or None, "figures": self.figures,
            "received_at": self.received_at.isoformat(), "url": f"/runs/{self.run_id}/",
            "artifacts_url": f"/api/robotics/result/{self.run_id}/artifacts/",
        }


class Artifact(models.Model):
    """A file uploaded for a run: a video (mp4), a plot (png/svg), its trace (jsonl), its config (toml) or its 3D
    replay (replay.json)."""

    VIDEO, PLOT, TRACE, CONFIG, REPLAY = "video", "plot", "trace", "config", "replay"
    result = models.ForeignKey(Result, on_delete=models.CASCADE, related_name="artifacts")
    name = models.CharField(max_length=100)
    kind = models.CharField(max_length=10, choices=[(k, k) for k in (VIDEO, PLOT, TRACE, CONFIG, REPLAY)])
    content_type = models.CharField(max_length=50)
    size = models.BigIntegerField()
    sha256 = models.CharField(max_length=64)
    path = models.CharField(max_length=300, help_text="relative to the media folder")
    uploaded_at = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["kind", "name"]
        constraints = [models.UniqueConstraint(fields=["result", "name"], name="artifact_name_unique_in_run")]

    def __str__(self) -> str:
        return f"{self.name} ({self.kind}, {self.size} bytes)"

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "kind": self.kind, "content_type": self.content_type, "size": self.size,
                "sha256": self.sha256, "url": f"/artifacts/{self.pk}/{self.name}"}


from robokit.server.assignments import Assignment, ModerationEvent, Submission, TrainingRun  # noqa: E402

__all__ = ["Artifact", "Assignment", "Classroom", "ModerationEvent", "Project", "Result", "Student", "Submission",
           "Token", "TrainingRun"]
