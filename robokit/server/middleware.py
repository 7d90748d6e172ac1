"""One access line per request (method, path - never the query string or headers -, status, milliseconds), and a
Content-Security-Policy on every HTML page."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

log = logging.getLogger("robokit.server.access")


class AccessLogMiddleware:
    """Logs ``POST /api/robotics/result/ 201 12.3 ms``. Tokens travel in headers and form bodies only, so
    nothing logged here can contain one."""

    def __init__(self, get_response: Callable[[Any], Any]) -> None:
        self.get_response = get_response

    def __call__(self, request: Any) -> Any:
        start = time.perf_counter()
        response = self.get_response(request)
        ms = (time.perf_counter() - start) * 1000
        log.info("%s %s %s %.1f ms", request.method, request.path, response.status_code, ms)
        return response


PAGE_CSP = ("default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
            "media-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'")
"""Scripts, styles, images and media only from this server (the admin's scripts are files too); inline styles are
allowed for the state timeline's bar widths; nothing may frame a page, plugins are off, forms post only here."""


class ContentSecurityPolicyMiddleware:
    """Adds :data:`PAGE_CSP` to every HTML answer that has no policy of its own (an uploaded file keeps its
    stricter sandboxing one)."""

    def __init__(self, get_response: Callable[[Any], Any]) -> None:
        self.get_response = get_response

    def __call__(self, request: Any) -> Any:
        response = self.get_response(request)
        if response.get("Content-Type", "").startswith("text/html") and "Content-Security-Policy" not in response:
            response["Content-Security-Policy"] = PAGE_CSP
        return response
