"""Watch and drive a running robot from a browser: ``robokit run CONFIG --live`` (see ``docs/live.md``).

:class:`LiveView` joins a run as a plugin (its lifecycle hooks) and a monitor in the loop; it publishes the latest
state into a one-slot buffer that a small HTTP server (:mod:`robokit.live.server`) streams to the page. The loop
never waits for the page.
"""

from robokit.live.view import LiveView

__all__ = ["LiveView"]
