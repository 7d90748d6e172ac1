"""The 3D replay on the server's run page, drawn from the run's uploaded ``replay.json`` (the data ``robokit view``
embeds in its offline page, made from the run record by the student's robokit when it uploads the run's files).

The scripts are robokit's package data, served as files: the viewer (three.js with its orbit controls,
``robokit/data/three.min.js``) and robokit's replay script (``robokit/data/replay.js``). The page's policy allows
scripts from this server only, so a small static script (``course/replay_boot.js``) fetches the data and then loads the
replay script. The server never rebuilds a scene: nothing of a student's URDFs or meshes is loaded here.
"""

from __future__ import annotations

from html import escape
from pathlib import Path
from typing import Any

from django.http import FileResponse, Http404, HttpRequest, HttpResponse
from django.templatetags.static import static
from django.urls import reverse

from robokit.record.replay import REPLAY_CSS, REPLAY_SCRIPT, replay_markup, viewer_path


def _script(path: Path | None) -> HttpResponse:
    if path is None or not path.is_file():
        raise Http404("the replay's viewer is missing from this server's robokit install (reinstall robokit)")
    response = FileResponse(path.open("rb"), content_type="text/javascript; charset=utf-8")
    response["Cache-Control"] = "public, max-age=3600"
    return response


def viewer_js(request: HttpRequest) -> HttpResponse:
    """The replay's viewer: three.js with its orbit controls (``robokit/data/three.min.js``)."""
    return _script(viewer_path())


def replay_js(request: HttpRequest) -> HttpResponse:
    """robokit's replay script (the one ``robokit view`` inlines)."""
    return _script(REPLAY_SCRIPT)


def replay_context(artifact: Any) -> dict[str, Any]:
    """What ``course/run.html`` needs to draw the replay of ``artifact`` (a ``replay`` Artifact), or nothing."""
    if artifact is None:
        return {}
    if viewer_path() is None:
        return {"replay_missing": True}
    data = reverse("artifact", args=[artifact.pk, artifact.name])
    attrs = f" data-src='{escape(data)}' data-script='{escape(reverse('replay-script'))}'"
    return {"replay_markup": replay_markup(attrs), "replay_css": REPLAY_CSS, "replay_boot": static(
        "course/replay_boot.js"), "replay_viewer": reverse("replay-viewer")}
