"""A fair share of the evaluation queue: which submission a queue task evaluates, and who may submit now.

Every submission queues one task, but a task is a *ticket*, not a promise to evaluate that one submission: it
evaluates the fairest waiting submission (:func:`claim`). Fairest means, in order:

1. the student with the fewest submissions being evaluated now,
2. then the student served least recently (never served first),
3. then the oldest submission.

So one student's backlog never delays another student's first submission: after each evaluation the next goes to
someone who has waited longer. A ticket's claim is stored on the submission (``claim``), so a task that comes back
after its worker died resumes the submission it had claimed; a conditional update makes two workers never claim the
same one.

The limits a student meets when submitting (:func:`admit`), per assignment: at most ``max_waiting`` submissions
queued or being evaluated at a time, and at most ``max_per_day`` in any 24 hours (0: no daily limit). A teacher's
re-evaluation counts against neither.
"""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.db import transaction
from django.db.models import Count, Max, Q
from django.utils import timezone

from robokit.server.assignments import Assignment, ModerationEvent, Submission

FINISHED = (Submission.DONE, Submission.ERROR)
DAY = dt.timedelta(hours=24)


class LimitReached(Exception):
    """A submission over the assignment's limits; the message says when the student may submit again."""

    def __init__(self, field: str, message: str, retry_after: int) -> None:
        super().__init__(message)
        self.field, self.message, self.retry_after = field, message, retry_after


def admit(assignment: Assignment, student_id: int, now: dt.datetime | None = None) -> None:
    """Refuse a new submission over ``assignment``'s limits for the student. Call it inside the transaction that
    stores the submission: it locks the student's row first, so two posts at once are counted one after the other.

    Raises:
        LimitReached: with the time (or the event) after which the student may submit again.
    """
    from robokit.server.models import Student

    now = now or timezone.now()
    list(Student.objects.select_for_update().filter(pk=student_id).values_list("pk", flat=True))
    mine = Submission.objects.filter(assignment=assignment, student_id=student_id)
    # a graded submission the teacher had evaluated again waits once more, but on the teacher's account
    waiting = list(mine.exclude(status__in=FINISHED).exclude(moderation__action=ModerationEvent.REEVALUATE)
                   .order_by("submitted_at").values_list("pk", flat=True))
    if assignment.max_waiting and len(waiting) >= assignment.max_waiting:
        ids = ", ".join(str(pk) for pk in waiting)
        raise LimitReached("max_waiting", f"you already have {len(waiting)} submission(s) of {assignment.name!r} "
                           f"waiting for evaluation ({ids}); you may submit again when "
                           f"{'it' if len(waiting) == 1 else 'one'} is graded "
                           f"(follow it with 'robokit submit --wait')", 60)
    if assignment.max_per_day:
        recent = list(mine.filter(submitted_at__gt=now - DAY).order_by("submitted_at")
                      .values_list("submitted_at", flat=True))
        over = len(recent) - assignment.max_per_day
        if over >= 0:
            # the window has room once the oldest `over + 1` of them are older than a day (a teacher may have
            # lowered the limit below what the student had made)
            again = recent[over] + DAY
            limit = "the limit" if not over else f"the limit is {assignment.max_per_day}"
            raise LimitReached("max_per_day", f"you have made {len(recent)} submissions of {assignment.name!r} in "
                               f"the last 24 hours ({limit}); you may submit again at "
                               f"{again.isoformat(timespec='seconds')}", max(1, int((again - now).total_seconds())))


def claim(ticket: int) -> int | None:
    """The submission a queue task evaluates: the one its ``ticket`` already claimed and has not finished, else the
    fairest waiting one, now claimed; None when nothing waits. A ticket is the id of the submission that queued
    the task, or minus the moderation event's id for a teacher's re-evaluation (tickets are never shared).

    Without workers (``settings.QUEUE_SYNC``) the posting process evaluates its own submission: ``ticket``.
    """
    from django.conf import settings

    if getattr(settings, "QUEUE_SYNC", False):
        return ticket
    resumed = Submission.objects.filter(claim=ticket).exclude(status__in=FINISHED).order_by("pk").first()
    if resumed is not None:
        return resumed.pk
    for _ in range(100):  # another worker may take the pick first: take the next
        pick = fairest()
        if pick is None:
            return None
        if Submission.objects.filter(pk=pick, claim__isnull=True, status=Submission.QUEUED).update(
                claim=ticket, claimed_at=timezone.now()):
            return pick
    return None


def fairest() -> int | None:
    """The waiting, unclaimed submission to evaluate next (see the module's rules)."""
    with transaction.atomic():
        waiting = list(Submission.objects.filter(status=Submission.QUEUED, claim__isnull=True)
                       .order_by("submitted_at", "pk").values_list("pk", "student_id", "submitted_at")[:1000])
        if not waiting:
            return None
        students = {s for _, s, _ in waiting}
        load: dict[int, dict[str, Any]] = {row["student_id"]: row for row in (
            Submission.objects.filter(student_id__in=students).values("student_id").annotate(
                busy=Count("pk", filter=Q(claim__isnull=False) & ~Q(status__in=FINISHED)),
                last=Max("claimed_at")))}
    never = dt.datetime.min.replace(tzinfo=dt.timezone.utc)

    def key(row: tuple[int, int, dt.datetime]) -> tuple[Any, ...]:
        pk, student, submitted = row
        stats = load.get(student, {})
        return (stats.get("busy") or 0, stats.get("last") or never, submitted, pk)

    return min(waiting, key=key)[0]
