"""The course server: a Django project and app that collects robokit results and shows them to the teacher.

Nothing in robokit's core imports this package; ``robokit serve`` and ``robokit manage`` import it (and Django)
only when they run. Settings come from the environment (see :mod:`robokit.server.settings`).
"""

DATA_ENV = "ROBOKIT_SERVER_DATA"
"""Environment variable naming the server's data folder (SQLite database, uploaded artifacts, secret key)."""
DEFAULT_DATA_DIR = "robokit-server"
