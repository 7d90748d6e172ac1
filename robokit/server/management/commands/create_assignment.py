"""``robokit manage create_assignment CLASS NAME --config FILE [--allow KEY ...] [--seeds A:B] [--due ...]``."""

from __future__ import annotations

import datetime as dt
from pathlib import Path
from typing import Any

from django.conf import settings
from django.core.management.base import BaseCommand, CommandError, CommandParser
from django.utils import timezone

from robokit.server.management.commands._common import classroom
from robokit.server.models import Assignment, Project


def when(text: str | None, option: str) -> dt.datetime | None:
    """An ISO 8601 date-time (``2026-12-04T18:00``, ``2026-12-04 18:00+09:00``); no zone = the server's (UTC)."""
    if not text:
        return None
    try:
        value = dt.datetime.fromisoformat(text)
    except ValueError:
        raise CommandError(f"{option}: expected a date and time like 2026-12-04T18:00+09:00, got {text!r}") from None
    return value if value.tzinfo is not None else timezone.make_aware(value, dt.timezone.utc)


class Command(BaseCommand):
    help = "Create (or update) an assignment: official config, keys students may change, seeds, due time."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("classroom")
        parser.add_argument("name")
        parser.add_argument("--config", required=True, help="the official config (TOML file)")
        parser.add_argument("--allow", action="append", default=[], metavar="KEY",
                            help="a dotted key students may change (repeat; '*' matches, e.g. 'behaviour.*')")
        parser.add_argument("--seeds", default="0:20", help="official seeds A:B (A..B-1), default 0:20")
        parser.add_argument("--kind", default="", help="project kind (default: the config's behaviour type)")
        parser.add_argument("--ranking", default="-success_rate,-wilson_low",
                            help="figures that rank submissions ('-' = higher is better)")
        parser.add_argument("--opens", help="opens at (ISO 8601); default now")
        parser.add_argument("--due", help="due at (ISO 8601); default never")
        parser.add_argument("--late", choices=[Assignment.ACCEPT, Assignment.REFUSE], default=Assignment.ACCEPT,
                            help="after the due time: accept and mark late (default) or refuse")
        parser.add_argument("--trial-seconds", type=float, default=60.0,
                            help="CPU-time budget of one trial in seconds of processor time (default 60); the "
                                 "config's world.max_time bounds its simulated time")
        parser.add_argument("--allow-plugins", action="store_true", help="students may send their own plugin "
                            "package with a submission (run only in the evaluation sandbox)")
        parser.add_argument("--max-waiting", type=int, default=1, metavar="N", help="submissions a student may have "
                            "queued or being evaluated at once (default 1; 0: no limit)")
        parser.add_argument("--max-per-day", type=int, default=10, metavar="N", help="submissions a student may "
                            "make in any 24 hours (default 10; 0: no limit)")

    def handle(self, *args: Any, **opts: Any) -> None:
        from robokit.errors import UserError
        from robokit.server.sandbox import process_cpu_limit
        from robokit.server.submitted import SubmissionError, parse_toml, validate_config
        from robokit.sweep.spec import parse_seeds

        room = classroom(opts["classroom"])
        path = Path(opts["config"])
        try:
            text = path.read_text(encoding="utf-8")
            seeds = list(parse_seeds(opts["seeds"]))
            validate_config(text, source=str(path))
        except OSError as exc:
            raise CommandError(f"--config {path}: {exc.strerror or exc}") from None
        except (UserError, SubmissionError) as exc:
            raise CommandError(f"{path}: {exc}") from None
        if process_cpu_limit(len(seeds), opts["trial_seconds"]) > settings.QUEUE_TIMEOUT:
            raise CommandError(f"--seeds/--trial-seconds: {len(seeds)} trials of up to {opts['trial_seconds']:g} s "
                               f"of CPU time may take longer than the queue lets one evaluation run "
                               f"({settings.QUEUE_TIMEOUT} s, ROBOKIT_QUEUE_TIMEOUT); use fewer seeds, a smaller "
                               f"budget or a longer timeout")
        if opts["max_waiting"] < 0 or opts["max_per_day"] < 0:
            raise CommandError("--max-waiting, --max-per-day: a whole number >= 0 (0: no limit)")
        behaviour = parse_toml(text).get("behaviour", {})
        kind = opts["kind"] or (behaviour.get("type", "") if isinstance(behaviour, dict) else "")
        project, _ = Project.objects.get_or_create(classroom=room, name=opts["name"],
                                                   defaults={"ranking": "-success,total_time"})
        fields = {"kind": kind, "config_text": text, "allowed_keys": opts["allow"], "seeds": seeds,
                  "ranking": opts["ranking"], "trial_seconds": opts["trial_seconds"],
                  "opens_at": when(opts["opens"], "--opens"), "due_at": when(opts["due"], "--due"),
                  "late_policy": opts["late"], "allow_plugins": opts["allow_plugins"], "project": project,
                  "max_waiting": opts["max_waiting"], "max_per_day": opts["max_per_day"]}
        assignment, created = Assignment.objects.update_or_create(classroom=room, name=opts["name"], defaults=fields)
        due = assignment.due_at.isoformat() if assignment.due_at else "no due time"
        self.stdout.write(f"assignment {assignment.name!r} {'created' if created else 'updated'} in class "
                          f"{room.name!r} (id {assignment.pk}): {len(seeds)} official seeds, {due}, late work "
                          f"{'refused' if assignment.late_policy == Assignment.REFUSE else 'accepted and marked'}; "
                          f"students may change: {', '.join(assignment.allowed_keys) or 'nothing'}"
                          + ("; students may send their own plugin package" if assignment.allow_plugins else ""))
