"""Assignments, students' submissions, moderation and training runs (imported by :mod:`robokit.server.models`).

An assignment belongs to a class: an official config, the keys students may change, the official seeds, a
ranking, opens/due times, a late policy and whether students may send their own plugin package. A submission is a
student's config (and plugin package) for it; the queue evaluates it on
the official seeds and stores one official :class:`~robokit.server.models.Result` per seed (its ``run_id`` is
derived from the submission and the seed, so a trial can never be stored twice).
"""

from __future__ import annotations

import fnmatch
import uuid
from typing import Any

from django.conf import settings
from django.db import models


class Assignment(models.Model):
    ACCEPT, REFUSE = "accept", "refuse"
    classroom = models.ForeignKey("course.Classroom", on_delete=models.CASCADE, related_name="assignments")
    name = models.CharField(max_length=100)
    kind = models.CharField(max_length=50, blank=True, help_text="project kind, e.g. sort, go_to_goal, drop_test")
    config_text = models.TextField(help_text="the official config (TOML)")
    allowed_keys = models.JSONField(default=list, blank=True,
                                    help_text="dotted keys students may change; '*' matches one or more levels")
    seeds = models.JSONField(default=list, help_text="official seeds, each submission is run on every one")
    ranking = models.CharField(max_length=300, blank=True, default="-success_rate,-wilson_low")
    trial_seconds = models.FloatField(default=60.0, help_text="CPU-time budget of one trial (seconds of processor "
                                      "time; the config's max_time bounds its simulated time)")
    opens_at = models.DateTimeField(null=True, blank=True)
    due_at = models.DateTimeField(null=True, blank=True)
    late_policy = models.CharField(max_length=10, default=ACCEPT,
                                   choices=[(ACCEPT, "accept and mark late"), (REFUSE, "refuse")])
    allow_plugins = models.BooleanField(default=False, help_text="students may send their own plugin package "
                                        "(Python code, run only in the evaluation sandbox)")
    max_waiting = models.PositiveIntegerField(default=1, help_text="submissions a student may have queued or "
                                              "being evaluated at once")
    max_per_day = models.PositiveIntegerField(default=10, help_text="submissions a student may make in any 24 "
                                              "hours (0: no limit)")
    project = models.OneToOneField("course.Project", on_delete=models.PROTECT, related_name="assignment")
    created_at = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["due_at", "name"]
        constraints = [models.UniqueConstraint(fields=["classroom", "name"], name="assignment_name_unique_in_class")]

    def __str__(self) -> str:
        return self.name

    def clean(self) -> None:
        """The admin's check: the official config passes robokit's validation; seeds are whole numbers."""
        from django.core.exceptions import ValidationError

        from robokit.server.submitted import SubmissionError, validate_config

        try:
            validate_config(self.config_text, source="official config")
        except SubmissionError as exc:
            raise ValidationError({"config_text": str(exc)}) from None
        if not isinstance(self.seeds, list) or not self.seeds or not all(
                isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in self.seeds):
            raise ValidationError({"seeds": "a list of whole numbers >= 0, e.g. [0, 1, 2]"})

    def may_change(self, key: str) -> bool:
        """Whether students may change the dotted ``key`` (``a.b.c``); ``a.*`` allows everything under ``a``."""
        return any(fnmatch.fnmatchcase(key, pattern) for pattern in self.allowed_keys)

    def check_config(self, text: str, *, validate: bool = True) -> None:
        """Refuse a submitted config that changes a key students may not change, names a file it does not bring,
        or that robokit's config check refuses (``validate``; off for a config that uses types of the student's
        own plugin: the sandbox checks it then).

        Raises:
            SubmissionError: naming the first such key.
        """
        from robokit.server.submitted import SubmissionError, changed_keys, check_paths, parse_toml, validate_config

        submitted = parse_toml(text)
        official = parse_toml(self.config_text, "official config")
        for key in changed_keys(official, submitted):
            if key == "world.seed":
                continue  # the official seeds replace it anyway
            if not self.may_change(key):
                allowed = ", ".join(self.allowed_keys) or "none"
                raise SubmissionError(key, f"students may not change this key in {self.name!r} "
                                           f"(keys you may change: {allowed})")
        check_paths(submitted)
        if validate:
            validate_config(text)


class Submission(models.Model):
    """A student's config for an assignment. ``idempotency_key`` (the ``Idempotency-Key`` header) is unique per
    student, so a repeated post, even two at once, is one row. ``claim`` is the queue task (ticket) evaluating it:
    a task evaluates the fairest waiting submission (:mod:`robokit.server.fair_queue`), and one that comes back
    after its worker died resumes the submission it claimed."""

    QUEUED, RUNNING, DONE, ERROR = "queued", "running", "done", "error"
    uuid = models.UUIDField(default=uuid.uuid4, unique=True, editable=False)
    assignment = models.ForeignKey(Assignment, on_delete=models.CASCADE, related_name="submissions")
    student = models.ForeignKey("course.Student", on_delete=models.CASCADE, related_name="submissions")
    config_text = models.TextField()
    plugin_files = models.JSONField(default=dict, blank=True, help_text="the student's plugin package: {path: source}")
    plugin_modules = models.JSONField(default=list, blank=True, help_text="its top-level modules, imported as plugins")
    submitted_at = models.DateTimeField(auto_now_add=True, db_index=True)
    late = models.BooleanField(default=False)
    status = models.CharField(max_length=10, default=QUEUED,
                              choices=[(s, s) for s in (QUEUED, RUNNING, DONE, ERROR)])
    error = models.TextField(blank=True)
    attempts = models.IntegerField(default=0, help_text="times a worker started (or resumed) the evaluation")
    trials = models.IntegerField(default=0)
    succeeded = models.IntegerField(default=0)
    success_rate = models.FloatField(null=True, blank=True)
    wilson_low = models.FloatField(null=True, blank=True)
    wilson_high = models.FloatField(null=True, blank=True)
    summary = models.JSONField(default=dict, blank=True)
    finished_at = models.DateTimeField(null=True, blank=True)
    excluded = models.BooleanField(default=False, help_text="left out of the boards and grades (moderation log)")
    idempotency_key = models.CharField(max_length=64, null=True, blank=True,
                                       help_text="the post's Idempotency-Key: the same key is the same submission")
    claim = models.BigIntegerField(null=True, blank=True, db_index=True,
                                   help_text="the queue task evaluating it (see robokit.server.fair_queue)")
    claimed_at = models.DateTimeField(null=True, blank=True, help_text="when a worker took it up")
    worker = models.CharField(max_length=200, blank=True, help_text="the queue process evaluating it (host:pid/pid)")
    heartbeat = models.DateTimeField(null=True, blank=True, help_text="last sign of life of its worker")
    requeued = models.IntegerField(default=0, help_text="times it was handed back to the queue (a worker stopped)")
    note = models.CharField(max_length=300, blank=True, help_text="what happened to it, for the student")

    class Meta:
        ordering = ["-submitted_at", "-id"]
        constraints = [models.UniqueConstraint(fields=["student", "idempotency_key"],
                                               name="submission_key_unique_per_student")]

    def __str__(self) -> str:
        return f"{self.student.name} / {self.assignment.name} / {self.submitted_at:%Y-%m-%d %H:%M}"

    @property
    def figures(self) -> dict[str, Any]:
        """What the board ranks: the success rate, its Wilson bounds, and the medians of the trials' figures."""
        out: dict[str, Any] = {"success_rate": self.success_rate, "wilson_low": self.wilson_low,
                               "wilson_high": self.wilson_high}
        cells = self.summary.get("cells") or [{}]
        for name, stats in (cells[0].get("figures") or {}).items():
            out.setdefault(name, stats.get("median"))
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.pk, "uuid": str(self.uuid), "assignment": self.assignment.name,
                "student": self.student.name, "submitted_at": self.submitted_at.isoformat(), "late": self.late,
                "status": self.status, "note": self.note, "seeds": len(self.assignment.seeds),
                "plugins": self.plugin_modules,
                "success_rate": self.success_rate,
                "wilson95": [self.wilson_low, self.wilson_high], "url": f"/submissions/{self.pk}/"}


class ModerationEvent(models.Model):
    """The audit log: a teacher excluded a run or a submission from the boards (or put it back), or had a
    submission evaluated again, with the reason."""

    EXCLUDE, INCLUDE, REEVALUATE = "exclude", "include", "reevaluate"
    classroom = models.ForeignKey("course.Classroom", on_delete=models.CASCADE, related_name="moderation")
    result = models.ForeignKey("course.Result", on_delete=models.SET_NULL, null=True, blank=True,
                               related_name="moderation")
    submission = models.ForeignKey(Submission, on_delete=models.SET_NULL, null=True, blank=True,
                                   related_name="moderation")
    what = models.CharField(max_length=200, help_text="the run or submission, as text (kept if it is deleted)")
    action = models.CharField(max_length=10, choices=[(EXCLUDE, EXCLUDE), (INCLUDE, INCLUDE),
                                                      (REEVALUATE, REEVALUATE)])
    reason = models.TextField()
    teacher = models.ForeignKey(settings.AUTH_USER_MODEL, on_delete=models.PROTECT, related_name="moderation")
    at = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["-at", "-id"]


class TrainingRun(models.Model):
    """A training log from ``robokit.gym`` (JSON lines: steps, episodes, return, success) posted by a student."""

    run_id = models.CharField(max_length=64, unique=True)
    student = models.ForeignKey("course.Student", on_delete=models.CASCADE, related_name="training_runs")
    name = models.CharField(max_length=100, blank=True)
    points = models.JSONField(default=list, help_text="[{steps, episodes, return, success_rate}, ...]")
    received_at = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["-received_at"]
