"""Django settings for the course server, read from the environment.

================================  =========================================================================
variable                          meaning (default)
================================  =========================================================================
``ROBOKIT_SERVER_DATA``           data folder: SQLite database, uploaded artifacts, generated secret key
                                  (``./robokit-server``)
``DATABASE_URL``                  another database, e.g. ``postgres://user:pass@host/db`` (SQLite in the data
                                  folder)
``ROBOKIT_SECRET_KEY``            Django's secret key (generated once into ``<data>/secret_key`` by
                                  ``robokit serve``)
``ROBOKIT_ALLOWED_HOSTS``         comma-separated host names the server answers to (loopback names)
``ROBOKIT_DEBUG``                 ``1`` for Django's debug pages (off)
``ROBOKIT_HTTPS``                 ``1`` when served behind HTTPS: secure cookies, trust X-Forwarded-Proto (off)
``ROBOKIT_CSRF_TRUSTED_ORIGINS``  comma-separated origins for the login forms behind a proxy
                                  (e.g. ``https://robots.school.org``)
``ROBOKIT_MAX_RESULT_BYTES``      largest result body accepted (1 MiB)
``ROBOKIT_MAX_VIDEO_BYTES``       largest video upload (50 MiB); plots 5 MiB, traces 20 MiB
``ROBOKIT_QUEUE_TIMEOUT``         seconds one evaluation may take before the queue stops it (21600); what is
                                  stored stays, the rest is handed back
``ROBOKIT_QUEUE_RETRY``           seconds before the queue hands out again a task it never saw end (timeout + 60)
``ROBOKIT_QUEUE_HEARTBEAT``       seconds between two signs of life of a worker evaluating a submission (15)
``ROBOKIT_QUEUE_STALE``           seconds without a sign of life after which a submission goes back to the queue
                                  (90)
``ROBOKIT_QUEUE_SYNC``            ``1``: evaluate submissions in the posting process, without workers (off)
``ROBOKIT_WORKERS``               evaluation processes of ``robokit worker`` (set by ``--workers``)
================================  =========================================================================
"""

from __future__ import annotations

import os
import secrets
import tempfile
from pathlib import Path

import dj_database_url

from robokit.server import DATA_ENV, DEFAULT_DATA_DIR

DATA_DIR = Path(os.environ.get(DATA_ENV) or DEFAULT_DATA_DIR).resolve()


def _secret_key() -> str:
    """From the environment, else the data folder's key file, else a per-process key (sessions end on restart)."""
    key = os.environ.get("ROBOKIT_SECRET_KEY") or os.environ.get("DJANGO_SECRET_KEY")
    if key:
        return key
    path = DATA_DIR / "secret_key"
    if path.is_file():
        return path.read_text(encoding="utf-8").strip()
    return secrets.token_urlsafe(50)


def _flag(name: str) -> bool:
    return os.environ.get(name, "").strip().lower() in {"1", "true", "yes", "on"}


SECRET_KEY = _secret_key()
DEBUG = _flag("ROBOKIT_DEBUG")
ALLOWED_HOSTS = [h.strip() for h in os.environ.get("ROBOKIT_ALLOWED_HOSTS", "").split(",") if h.strip()] or [
    "127.0.0.1", "localhost", "[::1]", "testserver"]

INSTALLED_APPS = [
    "django.contrib.admin",
    "django.contrib.auth",
    "django.contrib.contenttypes",
    "django.contrib.sessions",
    "django.contrib.messages",
    "django.contrib.staticfiles",
    "robokit.server.apps.CourseConfig",
]

MIDDLEWARE = [
    "robokit.server.middleware.AccessLogMiddleware",
    "robokit.server.middleware.ContentSecurityPolicyMiddleware",
    "django.middleware.security.SecurityMiddleware",
    "whitenoise.middleware.WhiteNoiseMiddleware",
    "django.contrib.sessions.middleware.SessionMiddleware",
    "django.middleware.common.CommonMiddleware",
    "django.middleware.csrf.CsrfViewMiddleware",
    "django.contrib.auth.middleware.AuthenticationMiddleware",
    "django.contrib.messages.middleware.MessageMiddleware",
    "django.middleware.clickjacking.XFrameOptionsMiddleware",
]

ROOT_URLCONF = "robokit.server.urls"
WSGI_APPLICATION = "robokit.server.wsgi.application"
TEMPLATES = [{
    "BACKEND": "django.template.backends.django.DjangoTemplates",
    "DIRS": [],
    "APP_DIRS": True,
    "OPTIONS": {"context_processors": [
        "django.template.context_processors.request",
        "django.contrib.auth.context_processors.auth",
        "django.contrib.messages.context_processors.messages",
    ]},
}]

_SQLITE_OPTIONS = {
    # Concurrent writers: WAL lets readers run beside the one writer; the busy timeout makes a writer wait for the
    # lock instead of failing at once; IMMEDIATE takes the write lock when a transaction starts, so two
    # transactions never deadlock upgrading a read lock (the cause of "database is locked" under load).
    "timeout": 30,
    "transaction_mode": "IMMEDIATE",
    "init_command": "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=ON;",
}
DATABASES = {"default": dj_database_url.config(default=f"sqlite:///{DATA_DIR / 'db.sqlite3'}", conn_max_age=60)}
if DATABASES["default"]["ENGINE"] == "django.db.backends.sqlite3":
    DATABASES["default"]["CONN_MAX_AGE"] = 0  # one connection per request and thread; cheap for SQLite
    DATABASES["default"].setdefault("OPTIONS", {}).update(_SQLITE_OPTIONS)
    # Tests get a file database (deleted afterwards), not Django's shared-cache in-memory one, whose table locks
    # ignore the busy timeout: concurrent tests then see the same locking as a real server.
    DATABASES["default"]["TEST"] = {"NAME": os.path.join(tempfile.gettempdir(), f"robokit-test-{os.getpid()}.db")}
DEFAULT_AUTO_FIELD = "django.db.models.BigAutoField"

AUTH_PASSWORD_VALIDATORS = [
    {"NAME": "django.contrib.auth.password_validation.MinimumLengthValidator", "OPTIONS": {"min_length": 8}},
    {"NAME": "django.contrib.auth.password_validation.CommonPasswordValidator"},
]
LOGIN_URL = "login"
LOGIN_REDIRECT_URL = "home"
LOGOUT_REDIRECT_URL = "home"

LANGUAGE_CODE = "en"
TIME_ZONE = "UTC"
USE_I18N = True
USE_TZ = True

STATIC_URL = "static/"
STATIC_ROOT = os.environ.get("ROBOKIT_STATIC_ROOT") or None  # for collectstatic behind a web server
WHITENOISE_USE_FINDERS = True  # serve app and admin static files without collectstatic
MEDIA_ROOT = DATA_DIR / "media"

MAX_RESULT_BYTES = int(os.environ.get("ROBOKIT_MAX_RESULT_BYTES", 1 << 20))
MAX_VIDEO_BYTES = int(os.environ.get("ROBOKIT_MAX_VIDEO_BYTES", 50 << 20))
MAX_PLOT_BYTES = 5 << 20
MAX_TRACE_BYTES = 20 << 20
MAX_CONFIG_BYTES = 256 << 10
MAX_REPLAY_BYTES = 10 << 20  # the 3D replay's data: the Panda's meshes and the poses of a minute-long run
MAX_ARTIFACTS_PER_RUN = 30
DATA_UPLOAD_MAX_MEMORY_SIZE = MAX_RESULT_BYTES
FILE_UPLOAD_MAX_MEMORY_SIZE = 2 << 20

SESSION_COOKIE_HTTPONLY = True
SESSION_COOKIE_SAMESITE = "Lax"
SESSION_COOKIE_SECURE = CSRF_COOKIE_SECURE = _flag("ROBOKIT_HTTPS")
if _flag("ROBOKIT_HTTPS"):  # behind a TLS-terminating proxy that sets X-Forwarded-Proto
    SECURE_PROXY_SSL_HEADER = ("HTTP_X_FORWARDED_PROTO", "https")
CSRF_TRUSTED_ORIGINS = [o.strip() for o in os.environ.get("ROBOKIT_CSRF_TRUSTED_ORIGINS", "").split(",") if o.strip()]
SECURE_CONTENT_TYPE_NOSNIFF = True
X_FRAME_OPTIONS = "DENY"

LOGGING = {
    "version": 1,
    "disable_existing_loggers": False,
    "formatters": {"plain": {"format": "%(message)s"}},
    "handlers": {"stderr": {"class": "logging.StreamHandler", "formatter": "plain"}},
    # Access lines (method, path without query string, status, time) from AccessLogMiddleware. Django's own
    # request logger repeats 4xx lines: silenced (it would only say the same, and never headers).
    "loggers": {
        "robokit.server.access": {"handlers": ["stderr"], "level": "INFO", "propagate": False},
        "django.request": {"handlers": ["stderr"], "level": "ERROR", "propagate": False},
    },
}

INSTALLED_APPS.append("django_q")
QUEUE_TIMEOUT = int(os.environ.get("ROBOKIT_QUEUE_TIMEOUT", 6 * 3600))
QUEUE_HEARTBEAT = float(os.environ.get("ROBOKIT_QUEUE_HEARTBEAT", 15))
QUEUE_STALE = float(os.environ.get("ROBOKIT_QUEUE_STALE", 90))
Q_CLUSTER = {
    # django-q2 with its ORM broker: the queue is a table of this database (SQLite is enough for a class). A task
    # taken by a worker is locked for `retry` seconds and deleted when done. A worker killed mid-task stops its
    # submission's heartbeat: robokit.server.lease hands the submission back with a new task within about
    # QUEUE_STALE seconds; the old task, handed out again after `retry`, then finds nothing to do.
    "name": "robokit",
    "orm": "default",
    "workers": int(os.environ.get("ROBOKIT_WORKERS", 1)),
    "timeout": QUEUE_TIMEOUT,
    "retry": int(os.environ.get("ROBOKIT_QUEUE_RETRY", QUEUE_TIMEOUT + 60)),
    "max_attempts": 5,
    "ack_failures": True,
    "catch_up": False,
    "poll": 0.5,
    "bulk": 1,
    "save_limit": 1000,
    "label": "Task queue",
}
QUEUE_SYNC = _flag("ROBOKIT_QUEUE_SYNC")  # evaluate in the posting process (tests; a server without workers)
