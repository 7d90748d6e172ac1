"""One access line per request: method, path (never the query string or headers), status, milliseconds."""

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
