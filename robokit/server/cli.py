"""``robokit serve`` and ``robokit manage``. Django is imported only when one of them runs.

``robokit serve`` serves with waitress: a pure-Python, multi-threaded production WSGI server that runs the same on
Linux, macOS and Windows (a teacher's laptop), unlike Django's ``runserver`` (a development server, single-purpose,
not security-audited) or gunicorn (no Windows). For a large deployment, run ``gunicorn robokit.server.wsgi`` behind
a reverse proxy instead (docs/server.md).
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from robokit.errors import UserError
from robokit.server import DATA_ENV, DEFAULT_DATA_DIR
from robokit.server.private import DIR_MODE, narrow, private_dir, private_sqlite


def add_server_commands(sub: Any) -> None:
    """Register ``serve`` and ``manage`` on the ``robokit`` sub-parser set."""
    serve = sub.add_parser("serve", help="run the course server (results API and teacher's dashboard; Django)")
    serve.add_argument("--host", default="127.0.0.1", help="address to listen on (0.0.0.0: every interface)")
    serve.add_argument("--port", type=int, default=8000)
    serve.add_argument("--data", metavar="DIR", help=f"data folder: SQLite database, uploads, secret key "
                       f"(default ${DATA_ENV} or ./{DEFAULT_DATA_DIR})")
    serve.add_argument("--threads", type=int, default=8, help="worker threads (default 8)")
    serve.add_argument("--workers", type=int, default=1, metavar="N",
                       help="evaluation workers started beside the server (default 1; 0: run `robokit worker`)")
    serve.add_argument("--create-teacher", metavar="NAME", help="create a teacher login (password from "
                       "$ROBOKIT_TEACHER_PASSWORD or a prompt) and exit")
    serve.set_defaults(func=cmd_serve)
    worker = sub.add_parser("worker", help="run the course server's evaluation workers (the task queue)")
    worker.add_argument("--data", metavar="DIR", help="data folder (as for serve)")
    worker.add_argument("--workers", type=int, default=1, metavar="N", help="evaluation processes (default 1)")
    worker.set_defaults(func=cmd_worker)
    manage = sub.add_parser("manage", help="course server management: create_class, add_students, issue_token, "
                            "revoke_token, teacher_token, create_teacher, or any Django command",
                            add_help=False)
    manage.add_argument("--data", metavar="DIR", help="data folder (as for serve)")
    manage.add_argument("-h", "--help", dest="manage_help", action="store_true")  # ours; after COMMAND: Django's
    manage.add_argument("args", nargs=argparse.REMAINDER)
    manage.set_defaults(func=cmd_manage)


def setup(data: str | None) -> Path:
    """Point Django at the data folder (created, with a secret key file) and set it up; returns the folder."""
    from robokit.extras import require

    require("server", "the course server")  # Django, waitress, whitenoise, dj-database-url, lxml: before any work
    import django

    folder = Path(data or os.environ.get(DATA_ENV) or DEFAULT_DATA_DIR).resolve()
    try:
        private_dir(folder)
        if narrow(folder, DIR_MODE):
            print(f"robokit: data folder {folder} was readable by other users: now 0700", file=sys.stderr)
        key = folder / "secret_key"
        if not key.exists() and not os.environ.get("ROBOKIT_SECRET_KEY"):
            fd = os.open(key, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(fd, "w") as fh:
                import secrets  # hmac/hashlib: ~10 ms that every other command would pay

                fh.write(secrets.token_urlsafe(50))
    except OSError as exc:
        raise UserError(f"data folder {folder}: {exc.strerror or exc}") from None
    os.environ[DATA_ENV] = str(folder)
    os.environ["DJANGO_SETTINGS_MODULE"] = "robokit.server.settings"
    django.setup()
    _private_database()
    return folder


def _private_database() -> None:
    from django.conf import settings

    try:
        for path in private_sqlite(settings.DATABASES["default"]):
            print(f"robokit: {path} was readable by other users: now 0600", file=sys.stderr)
    except OSError as exc:
        raise UserError(f"database {settings.DATABASES['default'].get('NAME')}: {exc.strerror or exc}") from None


def describe_database() -> str:
    """Where the database is, without any password."""
    from django.conf import settings

    db = settings.DATABASES["default"]
    if db["ENGINE"].endswith("sqlite3"):
        return f"SQLite {db['NAME']}"
    where = f"{db.get('HOST') or 'localhost'}{':' + str(db['PORT']) if db.get('PORT') else ''}"
    return f"{db['ENGINE'].rsplit('.', 1)[-1]} database {db.get('NAME')!r} on {where} (DATABASE_URL)"


def migrate() -> None:
    from django.core.management import call_command
    from django.db import DatabaseError

    try:
        call_command("migrate", interactive=False, verbosity=0)
    except DatabaseError as exc:
        raise UserError(f"database {describe_database()}: {exc}") from None


def prepare_plugins() -> None:
    """Discover and import every plugin type once, completely, before the process takes work: the web server's
    threads and the queue's processes then only read the plugin tables, never fill them."""
    from robokit.sweep.trial import plugins_for

    plugins_for(()).complete()


class _Stop:
    """SIGTERM / SIGINT for a process that serves until told to stop: the first signal asks it to stop (and breaks
    out of the wait it is in, when :attr:`breakable`); later ones are noted and change nothing, so stopping (the
    workers above all) is never itself cut short."""

    def __init__(self) -> None:
        self.signal: str | None = None
        self.breakable = False
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, self._handle)

    def _handle(self, signum: int, _frame: Any) -> None:
        if self.signal is not None:
            return
        self.signal = signal.Signals(signum).name
        if self.breakable:
            self.breakable = False
            raise KeyboardInterrupt


def cmd_serve(args: argparse.Namespace) -> int:
    """``robokit serve``: migrate, say where the database is, serve until Ctrl-C / SIGTERM (then stop its
    workers, always)."""
    folder = setup(args.data)
    migrate()
    if args.create_teacher:
        return _manage(["create_teacher", args.create_teacher])
    from django.conf import settings
    from waitress.server import create_server

    from robokit.server.wsgi import application

    prepare_plugins()  # wsgi did already; said here too, so the order is plain
    if args.host in ("0.0.0.0", "::") and not os.environ.get("ROBOKIT_ALLOWED_HOSTS"):
        settings.ALLOWED_HOSTS = ["*"]
    try:
        server = create_server(application, host=args.host, port=args.port, threads=args.threads,
                               max_request_body_size=_max_body(settings), ident="robokit")
    except OSError as exc:
        raise UserError(f"cannot listen on {args.host}:{args.port}: {exc.strerror or exc}") from None
    print(f"robokit serve: database {describe_database()}; uploads in {settings.MEDIA_ROOT}", flush=True)
    host = f"[{args.host}]" if ":" in args.host else args.host
    stop = _Stop()
    workers = None
    try:
        workers = _start_workers(folder, args.workers, settings)
        print(f"robokit serve: http://{host}:{server.effective_port}/ (results: POST /api/robotics/result/; "
              f"waitress, {args.threads} threads; data {folder}) - Ctrl-C stops", flush=True)
        stop.breakable = stop.signal is None
        if stop.breakable:
            server.run()  # returns on the signal (waitress catches the KeyboardInterrupt and closes)
    except KeyboardInterrupt:
        pass
    finally:
        stop.breakable = False
        server.close()
        _stop_workers(workers)
    print("robokit serve: stopped", file=sys.stderr)
    return 0


WORKER_OF_ENV = "ROBOKIT_WORKER_OF"
"""Set by ``robokit serve`` for the ``robokit worker`` it starts: the server's process id (the worker stops when
that process is gone, even if it was killed)."""


def _start_workers(folder: Path, n: int, settings: Any) -> subprocess.Popen[bytes] | None:
    """``robokit worker --workers N`` beside the server, in a session of its own (a Ctrl-C at the terminal reaches
    the server, which stops the worker: it hands back what it was evaluating)."""
    if n <= 0 or getattr(settings, "QUEUE_SYNC", False):
        return None
    proc = subprocess.Popen([sys.executable, "-m", "robokit.cli", "worker", "--data", str(folder),
                             "--workers", str(n)], env={**os.environ, WORKER_OF_ENV: str(os.getpid())},
                            start_new_session=True)
    print(f"robokit serve: {n} evaluation worker{'s' if n != 1 else ''} (robokit worker, pid {proc.pid})",
          flush=True)
    return proc


def _stop_workers(proc: subprocess.Popen[bytes] | None) -> None:
    """SIGTERM to the worker (it hands back its submissions and ends its processes in a second or two); SIGKILL to
    its whole session if it has not ended after 30 s."""
    if proc is None:
        return
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            pass
    if hasattr(os, "killpg"):
        try:
            os.killpg(proc.pid, signal.SIGKILL)  # anything of its session still there (a stuck or killed worker)
        except (ProcessLookupError, PermissionError):
            pass
    else:
        proc.kill()
    proc.wait()


def cmd_worker(args: argparse.Namespace) -> int:
    """``robokit worker``: django-q2's cluster on the server's database. Before it takes work: plugins loaded,
    scratch folders of stopped evaluations removed, submissions of stopped workers handed back; then every
    ``QUEUE_STALE / 3`` seconds the hand-back again. SIGTERM / SIGINT: its queue processes and their sandboxes are
    ended at once and what they were evaluating goes back to the queue (no trial is lost, none graded by the
    stop)."""
    import socket

    n = max(1, args.workers)
    os.environ["ROBOKIT_WORKERS"] = str(n)
    setup(args.data)
    migrate()
    from django import db
    from django.conf import settings

    from robokit.server import lease
    from robokit.server.sandbox import remove_stale_scratch

    name = f"{socket.gethostname()}:{os.getpid()}"
    os.environ[lease.WORKER_ENV] = name
    prepare_plugins()
    removed = remove_stale_scratch()
    if removed:
        print(f"robokit worker: removed {len(removed)} scratch folder(s) of stopped evaluations", flush=True)
    _reap(lease)
    lease.top_up()
    from django_q.cluster import Cluster

    print(f"robokit worker: {n} evaluation process(es) on {describe_database()}", flush=True)
    serve_pid = int(os.environ.get(WORKER_OF_ENV) or 0)
    cluster = Cluster()
    stop = _Stop()  # after the cluster's constructor, which installs handlers of its own that wait for the tasks
    db.connections.close_all()  # the cluster's processes are forked: none may share this process's connection
    try:
        cluster.start()
        every, last = float(settings.QUEUE_STALE) / 3, time.monotonic()
        while stop.signal is None and cluster.sentinel is not None and cluster.sentinel.is_alive():
            if serve_pid and os.getppid() != serve_pid:
                print("robokit worker: its server is gone: stopping", file=sys.stderr, flush=True)
                break
            if time.monotonic() - last >= every:
                _reap(lease)
                last = time.monotonic()
            cluster.sentinel.join(timeout=1.0)
    finally:
        _end_descendants()
        back = lease.hand_back(name, "the worker evaluating it was stopped")
        if back:
            print(f"robokit worker: handed {len(back)} submission(s) back to the queue", file=sys.stderr, flush=True)
    print("robokit worker: stopped", file=sys.stderr, flush=True)
    return 0


def _reap(lease: Any) -> None:
    from django.db import DatabaseError, close_old_connections

    try:
        back = lease.reap_stale()
    except DatabaseError as exc:  # the database away for a moment: next time
        print(f"robokit worker: could not look for stopped evaluations: {exc}", file=sys.stderr, flush=True)
        close_old_connections()
        return
    if back:
        print(f"robokit worker: handed {len(back)} submission(s) of a stopped worker back to the queue "
              f"({', '.join(map(str, back))})", flush=True)


def _end_descendants() -> None:
    """SIGKILL every process this one started, and theirs (queue processes, sandboxes)."""
    import psutil

    procs = psutil.Process().children(recursive=True)
    for p in procs:
        try:
            p.kill()
        except psutil.NoSuchProcess:
            pass
    psutil.wait_procs(procs, timeout=10)


def _max_body(settings: Any) -> int:
    from robokit.server.api import max_artifact_request

    return max(settings.MAX_RESULT_BYTES, max_artifact_request()) + (1 << 20)


def cmd_manage(args: argparse.Namespace) -> int:
    """``robokit manage COMMAND ...``: a Django management command on the server's database."""
    if args.manage_help or not args.args or args.args[0] in ("-h", "--help"):
        print("usage: robokit manage [--data DIR] COMMAND [ARGS]\n\ncourse commands: create_teacher NAME | "
              "create_class NAME --teacher USER [--allow-unverified] | add_students CLASS NAME... [--file F] | "
              "issue_token CLASS STUDENT | revoke_token CLASS STUDENT | teacher_token CLASS --teacher USER | "
              "create_assignment CLASS NAME --config FILE [--allow KEY ...] [--seeds A:B] [--due WHEN]\n"
              "any Django command works too (migrate, changepassword, dbshell, help ...)")
        return 0
    setup(args.data)
    migrate()
    return _manage(args.args)


def _manage(argv: list[str]) -> int:
    from django.core.management import CommandError, call_command, execute_from_command_line

    if argv[0] == "help" or argv[0].startswith("-"):
        execute_from_command_line(["robokit manage", *argv])
        return 0
    try:
        call_command(*argv)
    except CommandError as exc:
        raise UserError(str(exc)) from None
    return 0
