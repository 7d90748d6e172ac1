"""Template filters of the course pages: ``{{ r.reason|scrub }}`` shows a reason without the server's paths."""

from __future__ import annotations

from django import template

from robokit.server.submitted import scrub as _scrub

register = template.Library()


@register.filter
def scrub(text: object) -> str:
    """The text with the server's folders taken out (see :func:`robokit.server.submitted.scrub`)."""
    return _scrub(str(text or ""))
