"""WSGI entry point: ``gunicorn robokit.server.wsgi`` (production) or ``robokit serve`` (waitress)."""

import os

from django.core.wsgi import get_wsgi_application

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "robokit.server.settings")
application = get_wsgi_application()
