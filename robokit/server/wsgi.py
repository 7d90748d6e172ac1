"""WSGI entry point: ``gunicorn robokit.server.wsgi`` (production) or ``robokit serve`` (waitress)."""

import os

from django.core.wsgi import get_wsgi_application

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "robokit.server.settings")
application = get_wsgi_application()

from django.conf import settings  # noqa: E402 - after Django is set up

from robokit.server.private import private_sqlite  # noqa: E402

private_sqlite(settings.DATABASES["default"])  # a new database file is 0600, whatever gunicorn's umask

from robokit.sweep.trial import plugins_for  # noqa: E402

plugins_for(()).complete()  # every plugin type loaded before the first request: the server's threads only read them

from robokit.record.fonts import warn_if_no_korean_font  # noqa: E402

warn_if_no_korean_font()  # the charts draw Korean: said once, at start, when no font can
