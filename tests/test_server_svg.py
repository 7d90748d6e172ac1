"""SVG uploads are stored rebuilt from a parse, never as sent: no script, event handler, foreign content or outside
link survives, however it is spelled (namespace prefixes, character references, data: URLs); a real matplotlib plot
keeps every shape. The stored files are judged by a second, independent parser (the standard library's) and, in the
slow tier, opened from disk in headless Chromium next to the originals: the originals' scripts run, the stored
files' do not."""

from __future__ import annotations

import base64
import hashlib
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any
from urllib.parse import quote

import pytest
from course_helpers import Course, post, robokit_payload

from robokit.server.models import Artifact, Result

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db

SVG, XLINK = "http://www.w3.org/2000/svg", "http://www.w3.org/1999/xlink"
RAN = "document.documentElement.setAttribute('data-ran','yes')"
"""What every hostile payload's script does: a mark the browser test reads back."""
HEAD = f'<svg xmlns="{SVG}" xmlns:xlink="{XLINK}" width="120" height="80">'
INNER = f'<svg xmlns="{SVG}"><script>{RAN}</script></svg>'

HOSTILE = {
    "script": f"{HEAD}<script>{RAN}</script><rect width='5' height='5'/></svg>",
    "prefixed_script": f'{HEAD}<s:script xmlns:s="{SVG}">{RAN}</s:script><rect width="5" height="5"/></svg>',
    "cdata_script": f"{HEAD}<script><![CDATA[{RAN}]]></script></svg>",
    "onload": f'{HEAD}<rect width="5" height="5" onload="{RAN}"/></svg>',
    "svg_onload": f'<svg xmlns="{SVG}" onload="{RAN}"><rect width="5" height="5"/></svg>',
    "prefixed_onload": f'{HEAD}<rect xmlns:s="{SVG}" s:onload="{RAN}" width="5" height="5"/></svg>',
    "javascript_entity": f'{HEAD}<a href="javascript&#58;{RAN}"><rect id="hit" width="80" height="60"/></a></svg>',
    "javascript_xlink": f'{HEAD}<a xlink:href="java&#x09;script&#x3A;{RAN}"><rect id="hit" width="80" '
                        'height="60"/></a></svg>',
    "use_data": f'{HEAD}<use href="data:image/svg+xml;base64,{base64.b64encode(INNER.encode()).decode()}#x"/></svg>',
    "use_data_xlink": f'{HEAD}<use xlink:href="data:image/svg+xml,{quote(INNER)}#x"/></svg>',
    "image_svg": f'{HEAD}<image href="data:image/svg+xml;base64,{base64.b64encode(INNER.encode()).decode()}"/>'
                 "</svg>",
    "foreign_object": f'{HEAD}<foreignObject width="50" height="50"><iframe xmlns="http://www.w3.org/1999/xhtml" '
                      f'src="javascript:{RAN}"/></foreignObject></svg>',
    "xhtml_script": f'{HEAD}<h:script xmlns:h="http://www.w3.org/1999/xhtml">{RAN}</h:script></svg>',
    "animate_href": f'{HEAD}<a><animate attributeName="href" to="javascript:{RAN}"/><rect id="hit" width="80" '
                    'height="60"/></a></svg>',
    "set_onclick": f'{HEAD}<rect id="hit" width="80" height="60"><set attributeName="onclick" to="{RAN}"/></rect>'
                   "</svg>",
    "css_url": f'{HEAD}<style>rect {{ fill: url(javascript:{RAN}) }} @import url(http://x/y.css);</style>'
               '<rect width="5" height="5" style="fill: url(http://x/y)" fill="url(http://x/#p)"/></svg>',
}
"""Each would run a script, load something or link out if stored as sent."""


@pytest.fixture
def media(settings: Any, tmp_path: Path) -> Path:
    settings.MEDIA_ROOT = tmp_path / "media"
    return Path(settings.MEDIA_ROOT)


def _upload(client: Any, course: Course, run: int, name: str, content: bytes) -> Any:
    from django.core.files.uploadedfile import SimpleUploadedFile

    payload = robokit_payload(run)
    post(client, payload, course.kim_token)
    return client.post(f"/api/robotics/result/{payload['run_id']}/artifacts/",
                       data={"f": SimpleUploadedFile(name, content)}, HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")


def _stored(media: Path, name: str) -> Path:
    artifact = Artifact.objects.get(name=name)
    return media / artifact.path


def _problems(data: bytes) -> list[str]:
    """What a browser could run or fetch in ``data``, read with the standard library's parser (not lxml)."""
    found = []
    for element in ET.fromstring(data).iter():
        ns, _, local = element.tag[1:].partition("}")
        if ns != SVG:
            found.append(f"element {element.tag}")
        if local in ("script", "foreignObject", "a", "animate", "set", "iframe", "handler"):
            found.append(f"element {local}")
        for key, value in element.attrib.items():
            bare = key.rsplit("}", 1)[-1]
            if bare.lower().startswith("on"):
                found.append(f"attribute {key}")
            if bare == "href" and not (value.startswith("#") or value.startswith("data:image/png;base64,")):
                found.append(f"link {value[:40]}")
            if "url(" in value.replace(" ", "") and "url(#" not in value.replace(" ", ""):
                found.append(f"url in {key}")
        if local == "style" and element.text and ("url(" in element.text or "@" in element.text):
            found.append("style loads")
    if b"javascript" in data.lower():
        found.append("javascript")
    return found


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_hostile_svg_is_stored_without_what_could_run(client: Any, course: Course, media: Path, case: str) -> None:
    sent = HOSTILE[case].encode()
    assert _problems(sent), "the sample itself must be hostile"
    resp = _upload(client, course, 1, "plot.svg", sent)
    assert resp.status_code == 201, resp.content
    stored = _stored(media, "plot.svg").read_bytes()
    assert stored != sent
    assert _problems(stored) == []
    assert resp.json()["artifacts"][0]["sha256"] == hashlib.sha256(stored).hexdigest()
    assert resp.json()["artifacts"][0]["size"] == len(stored)


def test_a_matplotlib_plot_keeps_every_shape_and_reuploads_idempotently(client: Any, course: Course,
                                                                       media: Path, tmp_path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot([0, 1, 2, 3], [0, 1, 0.5, 2], marker="o", label="gripper z")
    ax.imshow([[0, 1], [1, 0]], extent=(0, 1, 0, 1))  # an embedded PNG image
    ax.set_title("z (m)")
    ax.legend()
    fig.savefig(tmp_path / "z.svg")
    plt.close(fig)
    sent = (tmp_path / "z.svg").read_bytes()
    assert _upload(client, course, 2, "z.svg", sent).status_code == 201
    stored = _stored(media, "z.svg").read_bytes()
    assert _problems(stored) == []

    def shapes(data: bytes) -> dict[str, list[tuple[str, ...]]]:
        out: dict[str, list[tuple[str, ...]]] = {}
        for e in ET.fromstring(data).iter():
            local = e.tag.rsplit("}", 1)[-1]
            if local in ("path", "use", "image", "clipPath", "rect", "g", "style"):
                out.setdefault(local, []).append(tuple(sorted(f"{k.rsplit('}', 1)[-1]}={v}" for k, v in
                                                              e.attrib.items())) + ((e.text or "").strip(),))
        return out

    assert shapes(stored) == shapes(sent)  # every drawing element with all its attributes and text
    assert shapes(sent)["image"] and shapes(sent)["use"]
    root = ET.fromstring(stored)
    assert root.get("viewBox") == ET.fromstring(sent).get("viewBox")
    again = _upload(client, course, 2, "z.svg", sent)
    assert again.status_code == 200  # the same upload rebuilds to the same bytes


@pytest.mark.parametrize(("content", "words"), [
    (b'<?xml version="1.0"?><!DOCTYPE svg [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;">]>'
     b'<svg xmlns="http://www.w3.org/2000/svg"><text>&b;</text></svg>', "DTD internal subset"),
    (b'<!DOCTYPE svg SYSTEM "file:///etc/passwd" [<!ENTITY x SYSTEM "file:///etc/passwd">]><svg>&x;</svg>',
     "DTD internal subset"),
    (b'<svg xmlns="http://www.w3.org/2000/svg"><rect></svg>', "not well-formed"),
    (b"<html><body>hi</body></html>", "not an SVG image"),
    (b'<x:svg xmlns:x="http://example.org/not-svg"/>', "not an SVG image"),
    (b"\xff\xfe<svg/>", "not UTF-8"),
])
def test_svg_that_is_not_a_plain_svg_document_is_refused(client: Any, course: Course, media: Path, content: bytes,
                                                         words: str) -> None:
    resp = _upload(client, course, 3, "plot.svg", content)
    assert resp.status_code == 400 and words in resp.json()["error"]
    assert Artifact.objects.count() == 0


def test_doctype_without_internal_subset_is_accepted_and_dropped(client: Any, course: Course, media: Path) -> None:
    sent = (b'<?xml version="1.0"?>\n<!DOCTYPE svg PUBLIC "-//W3C//DTD SVG 1.1//EN" '
            b'"http://www.w3.org/Graphics/SVG/1.1/DTD/svg11.dtd">\n<svg xmlns="http://www.w3.org/2000/svg"/>')
    assert _upload(client, course, 4, "plot.svg", sent).status_code == 201
    assert b"DOCTYPE" not in _stored(media, "plot.svg").read_bytes()


def test_svgs_stored_by_an_earlier_version_are_rebuilt_by_the_migration(client: Any, course: Course,
                                                                         media: Path) -> None:
    import importlib

    from django.apps import apps

    payload = robokit_payload(5)
    post(client, payload, course.kim_token)
    record = Result.objects.get()
    old = {"old.svg": HOSTILE["prefixed_script"].encode(), "use.svg": HOSTILE["use_data"].encode(),
           "broken.svg": b'<svg xmlns="http://www.w3.org/2000/svg"><rect></svg>'}
    for name, data in old.items():  # as the earlier version stored them: the bytes as sent
        rel = f"artifacts/{payload['run_id']}/{name}"
        (media / rel).parent.mkdir(parents=True, exist_ok=True)
        (media / rel).write_bytes(data)
        Artifact.objects.create(result=record, name=name, kind="plot", content_type="image/svg+xml",
                                size=len(data), sha256=hashlib.sha256(data).hexdigest(), path=rel)
    importlib.import_module("robokit.server.migrations.0005_rebuild_stored_svgs").rebuild(apps, None)
    for name in ("old.svg", "use.svg"):
        stored = _stored(media, name).read_bytes()
        assert stored != old[name] and _problems(stored) == []
        row = Artifact.objects.get(name=name)
        assert (row.size, row.sha256) == (len(stored), hashlib.sha256(stored).hexdigest())
    assert not Artifact.objects.filter(name="broken.svg").exists()
    assert not (media / "artifacts" / payload["run_id"] / "broken.svg").exists()


CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"


@pytest.mark.slow
@pytest.mark.skipif(not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)),
                    reason="needs Debian's chromium and chromium-driver (installed by .ci/run)")
def test_stored_svgs_run_no_script_when_opened_from_disk_in_chromium(client: Any, course: Course, media: Path,
                                                                     tmp_path: Path) -> None:
    """Each original and its stored file are opened as files (no server, no CSP: as a student or teacher would open
    a downloaded file), every element is clicked, and the page is asked whether a payload left its mark."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    stored: dict[str, Path] = {}
    for i, (case, text) in enumerate(sorted(HOSTILE.items())):
        assert _upload(client, course, 100 + i, f"{case}.svg", text.encode()).status_code == 201
        stored[case] = _stored(media, f"{case}.svg")
        (tmp_path / f"sent-{case}.svg").write_text(text, encoding="utf-8")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--disable-background-networking", f"--user-data-dir={tmp_path / 'chrome'}"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)

    def ran(path: Path) -> bool:
        driver.get(path.as_uri())
        driver.execute_script("for (const e of document.querySelectorAll('*')) "
                              "e.dispatchEvent(new MouseEvent('click', {bubbles: true, cancelable: true}))")
        return bool(driver.execute_script("return document.documentElement && "
                                          "document.documentElement.getAttribute('data-ran') === 'yes'"))

    try:
        originals = {case: ran(tmp_path / f"sent-{case}.svg") for case in HOSTILE}
        # The control: these originals do run their script in this browser (so "no mark" below means something).
        for case in ("script", "prefixed_script", "cdata_script", "svg_onload", "javascript_entity",
                     "javascript_xlink"):
            assert originals[case], case
        assert {case: ran(path) for case, path in stored.items()} == dict.fromkeys(HOSTILE, False)
    finally:
        driver.quit()
