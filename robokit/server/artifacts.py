"""What an uploaded file really is, judged by its bytes (magic numbers), not by its name.

==========  ===================  ===============================================================
kind        names                accepted when
==========  ===================  ===============================================================
video       ``*.mp4``            an ISO base media file: ``ftyp`` box at byte 4
plot        ``*.png``            the 8-byte PNG signature
plot        ``*.svg``            well-formed XML whose root is ``<svg>``; stored re-serialised with
                                 only drawing elements and attributes (:mod:`robokit.server.svg`)
trace       ``*.jsonl``          UTF-8, every non-empty line a JSON object (robokit's trace)
config      ``*.toml``           UTF-8 TOML that parses
replay      ``replay.json``      the 3D replay's data as ``robokit view`` embeds it
                                 (:func:`robokit.record.replay.payload`): its fields and types,
                                 arrays whose sizes agree, camera frames only as PNG data URIs
==========  ===================  ===============================================================
"""

from __future__ import annotations

import base64
import binascii
import json
import re
import sys
from dataclasses import dataclass

from robokit.server.svg import SvgError, clean_svg

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,99}$")
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class ArtifactError(Exception):
    """An upload refused: the message says why (one line)."""


@dataclass(frozen=True)
class Kind:
    kind: str
    content_type: str
    limit_setting: str


KINDS = {
    ".mp4": Kind("video", "video/mp4", "MAX_VIDEO_BYTES"),
    ".png": Kind("plot", "image/png", "MAX_PLOT_BYTES"),
    ".svg": Kind("plot", "image/svg+xml", "MAX_PLOT_BYTES"),
    ".jsonl": Kind("trace", "application/jsonl", "MAX_TRACE_BYTES"),
    ".toml": Kind("config", "text/plain; charset=utf-8", "MAX_CONFIG_BYTES"),
    ".json": Kind("replay", "application/json", "MAX_REPLAY_BYTES"),
}
REPLAY_NAME = "replay.json"


def kind_for(name: str) -> Kind:
    """The kind an upload claims by its name.

    Raises:
        ArtifactError: a name with a path, odd characters, or an extension not accepted.
    """
    if not NAME.match(name) or ".." in name:
        raise ArtifactError(f"{name!r}: a file name (letters, digits, '.', '_', '-'; no folders) was expected")
    ext = "." + name.rsplit(".", 1)[-1].lower() if "." in name else ""
    if ext not in KINDS or (ext == ".json" and name != REPLAY_NAME):
        raise ArtifactError(f"{name!r}: only {', '.join(k for k in KINDS if k != '.json')} files and "
                            f"{REPLAY_NAME} are accepted")
    return KINDS[ext]


def check_content(name: str, kind: Kind, head: bytes, whole: bytes | None) -> bytes | None:
    """Check the bytes are what the name says.

    Args:
        name: The file name (for messages).
        kind: From :func:`kind_for`.
        head: The first bytes of the file (at least 16 when the file has them).
        whole: The whole file for text kinds (svg, jsonl, toml); None for binary kinds.

    Returns:
        The bytes to store instead of the upload (an SVG, rebuilt from its parse), or None to store it as sent.

    Raises:
        ArtifactError: the content does not match.
    """
    ext = name.rsplit(".", 1)[-1].lower()
    if ext == "mp4":
        if len(head) < 12 or head[4:8] != b"ftyp":
            raise ArtifactError(f"{name!r} is not an MP4 file (no 'ftyp' box at its start)")
        return None
    if ext == "png":
        if not head.startswith(PNG_SIGNATURE):
            raise ArtifactError(f"{name!r} is not a PNG file (no PNG signature)")
        return None
    assert whole is not None
    try:
        text = whole.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise ArtifactError(f"{name!r} is not UTF-8 text") from None
    if ext == "svg":
        try:
            return clean_svg(whole)
        except SvgError as exc:
            raise ArtifactError(f"{name!r} {exc}") from None
    if ext == "jsonl":
        _check_jsonl(name, text)
    elif ext == "json":
        check_replay(name, text)
    else:
        try:
            tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ArtifactError(f"{name!r} is not TOML: {exc}") from None
    return None


def _check_jsonl(name: str, text: str) -> None:
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            raise ArtifactError(f"{name!r} line {number} is not JSON") from None
        if not isinstance(record, dict):
            raise ArtifactError(f"{name!r} line {number} is not a JSON object")


def check_replay(name: str, text: str) -> None:
    """``replay.json``: the fields the replay script reads, with their types, and sample arrays whose sizes agree
    (``t``: N float32, ``poses``: N x links x 7 float32, base64). Camera frames must be PNG data URIs.

    Raises:
        ArtifactError: what is wrong, in one line.
    """
    try:
        data = json.loads(text)
    except ValueError:
        raise ArtifactError(f"{name!r} is not JSON") from None
    if not isinstance(data, dict):
        raise ArtifactError(f"{name!r} is not a JSON object")
    problem = _replay_problem(data)
    if problem:
        raise ArtifactError(f"{name!r} is not a robokit replay: {problem}")


def _replay_problem(data: dict[str, object]) -> str | None:
    kinds: dict[str, type | tuple[type, ...]] = {
        "links": list, "shapes": list, "meshes": list, "frames": list, "machines": list, "t": str, "poses": str,
        "duration": (int, float)}
    for key, kind in kinds.items():
        if not isinstance(data.get(key), kind):
            return f"'{key}' is missing or of the wrong type"
    links = data["links"]
    assert isinstance(links, list)
    if not all(isinstance(link, str) for link in links):
        return "'links' must be names"
    try:
        samples = len(base64.b64decode(str(data["t"]), validate=True)) // 4
        values = len(base64.b64decode(str(data["poses"]), validate=True)) // 4
    except (ValueError, binascii.Error):
        return "'t' and 'poses' must be base64"
    if values != samples * len(links) * 7:
        return (f"'poses' holds {values} numbers; {samples} samples of {len(links)} links need "
                f"{samples * len(links) * 7}")
    for items, key in ((data["shapes"], "shapes"), (data["meshes"], "meshes"), (data["frames"], "frames"),
                       (data["machines"], "machines")):
        assert isinstance(items, list)
        if not all(isinstance(item, dict) for item in items):
            return f"'{key}' must be objects"
    frames = data["frames"]
    assert isinstance(frames, list)
    if not all(str(f.get("png", "")).startswith("data:image/png;base64,") for f in frames):
        return "camera frames must be PNG data URIs"
    return None
