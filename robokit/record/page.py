"""``robokit view``: one self-contained HTML page for a run — it opens offline, from a file, with nothing beside it.

Everything is inside the file: the video and plots as ``data:`` URIs, the state diagrams as inline SVG (drawn by
:mod:`robokit.record.diagram`; Mermaid's JavaScript is not bundled), the config as text. Headings carry Korean
captions for the course's students; the fonts fall back to any installed Korean font (Noto Sans KR, NanumGothic).
"""

from __future__ import annotations

import base64
import json
import tempfile
from html import escape
from pathlib import Path
from typing import Any

import numpy as np

from robokit.record.diagram import machine_svg, mermaid_text
from robokit.record.format import RunRecord
from robokit.record.layout import noted_video
from robokit.record.replay import REPLAY_CSS

CSS = """
body { font-family: system-ui, "Noto Sans KR", "NanumGothic", "Nanum Gothic", "Apple SD Gothic Neo", sans-serif;
       margin: 0 auto; max-width: 1100px; padding: 16px 24px 48px; color: #222; background: #fff; }
h1 { font-size: 22px; margin: 8px 0 4px; } h2 { font-size: 17px; margin: 28px 0 8px; border-bottom: 1px solid #ddd; }
h2 .ko { color: #777; font-weight: normal; margin-left: 8px; }
.outcome { display: inline-block; padding: 3px 10px; border-radius: 12px; color: #fff; font-weight: bold; }
.succeeded { background: #2e7d32; } .failed, .error { background: #c62828; } .aborted { background: #ef6c00; }
table { border-collapse: collapse; font-size: 13px; } td, th { border: 1px solid #ddd; padding: 3px 8px; }
th { background: #f4f4f4; text-align: left; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
.figs td:first-child { font-weight: bold; } .plots img { max-width: 100%; border: 1px solid #eee; margin: 6px 0; }
pre { background: #f7f7f7; padding: 10px; overflow-x: auto; font-size: 12px; } video { max-width: 100%; }
.meta { color: #555; font-size: 13px; } .fsm { max-width: 100%; height: auto; display: block; margin: 6px 0; }
""" + REPLAY_CSS


def _data_uri(path: Path, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(path.read_bytes()).decode('ascii')}"


def find_video(rec: RunRecord) -> Path | None:
    """The run's own video, or None (the page then renders one): the video last made for the run (``video.json``)
    while the file still has the digest noted when it was made (a later run's video written over the same name is
    not this run's), else the run folder's own ``video.mp4``, which only this run's videos are written to."""
    noted = noted_video(rec.folder)
    if noted is not None:
        return noted
    own = rec.folder / "video.mp4"
    return own if own.is_file() else None


def _figures(result: dict[str, Any]) -> str:
    rows = [(k, v) for k, v in result.items() if isinstance(v, (int, float, str, bool)) or v is None]
    return "".join(f"<tr><td>{escape(str(k))}</td><td class='num'>{escape(str(v))}</td></tr>" for k, v in rows)


def _objects(result: dict[str, Any]) -> str:
    """The first list of dicts in the result (``objects`` of the sort, ``found`` of patrol_collect) as a table."""
    for key in ("objects", "found", *result):
        items = result.get(key)
        if isinstance(items, list) and items and all(isinstance(i, dict) for i in items):
            cols = list(dict.fromkeys(k for i in items for k in i))
            head = "".join(f"<th>{escape(c)}</th>" for c in cols)
            body = "".join("<tr>" + "".join(f"<td>{escape(_cell(i.get(c)))}</td>" for c in cols) + "</tr>"
                           for i in items)
            named = "" if key == "objects" else f"<p class='meta'>from the result's <code>{escape(key)}</code></p>"
            return f"{named}<table><tr>{head}</tr>{body}</table>"
    return "<p class='meta'>(this behaviour reports no object list)</p>"


def _cell(v: Any) -> str:
    if v is None:
        return ""
    return json.dumps(v, ensure_ascii=False) if isinstance(v, (list, dict)) else str(v)


def _section(title: str, korean: str, body: str) -> str:
    return f"<h2>{escape(title)}<span class='ko' lang='ko'>{escape(korean)}</span></h2>{body}"


def build_page(rec: RunRecord, video: Path | None, plots: list[Path], replay: str | None = None) -> str:
    """The page's HTML text."""
    r, header = rec.result, rec.header
    result = r.get("result") or {}
    outcome = str(r.get("outcome", "unknown"))
    config_name = Path(str(r.get("config") or header.get("config_path", "config"))).name
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{escape(config_name)} · "
             f"{rec.run_id[:8]} · robokit</title><meta name='viewport' content='width=device-width'>"
             f"<style>{CSS}</style></head><body>",
             f"<h1>{escape(config_name)} <span class='outcome {escape(outcome)}'>{escape(outcome)}</span></h1>",
             f"<p>{escape(str(r.get('reason', '')))}</p>",
             f"<p class='meta'>run {escape(rec.run_id)} · seed {escape(str(header.get('seed')))} · behaviour "
             f"{escape(str(r.get('behaviour')))} · sim {float(r.get('sim_time', 0)):.2f} s · wall "
             f"{float(r.get('wall_time', 0)):.2f} s · started {escape(str(r.get('started_at', '')))} · engine "
             f"{escape(' '.join(str(v) for v in (r.get('engine'), r.get('engine_version')) if v) or '?')} · robokit "
             f"{escape(str(header.get('robokit_version')))}</p>"]
    parts.append(_section("Headline figures", "주요 결과", f"<table class='figs'>{_figures(result)}</table>"))
    parts.append(_section("Objects", "물체", _objects(result)))
    if replay is not None:
        parts.append(_section("Replay", "3D 재생", replay + "<p class='meta'>drag to orbit, right-drag to pan, "
                              "scroll to zoom; click a state to jump to it</p>"))
    if video is not None:
        parts.append(_section("Video", "영상", f"<video id='run-video' controls muted playsinline preload='auto' "
                              f"src='{_data_uri(video, 'video/mp4')}'></video>"))
    occupancy = _occupancy_map(rec)
    if occupancy:
        parts.append(_section("Map", "지도", occupancy))
    if plots:
        imgs = "".join(f"<figure><img alt='{escape(p.stem)}' src='{_data_uri(p, _mime(p))}'>"
                       f"<figcaption class='meta'>{escape(p.name)}</figcaption></figure>" for p in plots)
        parts.append(_section("Plots", "그래프", f"<div class='plots'>{imgs}</div>"))
    spans = rec.spans()
    diagrams = []
    for m in header.get("machines", []):
        spent: dict[str, float] = {}
        for s in spans.get(m["name"], []):
            spent[s.state] = spent.get(s.state, 0.0) + (s.end - s.start)
        diagrams.append(f"<h3>{escape(m['name'])} ({escape(m['type'])})</h3>{machine_svg(m, spent)}"
                        f"<details><summary>Mermaid source</summary><pre>{escape(mermaid_text(m))}</pre></details>")
    if diagrams:
        parts.append(_section("State machines", "상태 기계", "".join(diagrams) +
                              "<p class='meta'>green: states this run visited, with the sim seconds spent there</p>"))
    config = header.get("config_text") or json.dumps(header.get("config", {}), indent=2)
    parts.append(_section("Config", "설정", f"<pre>{escape(config)}</pre>"))
    parts.append("</body></html>")
    return "".join(parts)


def _occupancy_map(rec: RunRecord) -> str:
    """The planner's saved map (``planner = "astar"``) with its planned paths and the driven path, or ''."""
    from robokit.planning.mapview import MAP_FILES, map_caption, map_svg

    if not all((rec.folder / name).is_file() for name in MAP_FILES):
        return ""
    driven = None
    drives = [s for s in (rec.header.get("config", {}).get("actuators") or {}).values()
              if isinstance(s, dict) and s.get("type") == "diff_drive"]
    if drives and rec.has_poses:
        track = rec.poses.get(f"base/{drives[0].get('robot', 'robot')}")
        if track is not None:
            driven = track[~np.isnan(track[:, 0]), :2]
    svg = map_svg(rec.folder, driven)
    return f"{svg}<p class='meta'>{map_caption(rec.folder)}</p>" if svg else ""


def _mime(path: Path) -> str:
    return "image/svg+xml" if path.suffix == ".svg" else "image/png"


def write_page(rec: RunRecord, out: Path, *, video: bool = True, replay: bool = True) -> Path:
    """Write the page to ``out``, making the video (if asked and missing), the 3D replay and the plots it embeds."""
    from robokit.record.plots import make_plots

    scene = None
    if replay and rec.has_poses:
        from robokit.record.replay import replay_html

        scene = replay_html(rec) or ("<p class='meta'>The 3D replay's viewer (robokit/data/three.min.js) is "
                                     "missing from this install: reinstall robokit</p>")

    clip = find_video(rec) if video else None
    if video and clip is None and rec.has_poses:
        from robokit.record.video import render_video

        clip = rec.folder / "video.mp4"
        render_video(rec, clip)
    plot_dir = rec.folder / "plots"
    plots = sorted(plot_dir.glob("*.png")) if plot_dir.is_dir() else []
    with tempfile.TemporaryDirectory() as tmp:
        if not plots:
            plots = make_plots(rec, Path(tmp))
        html = build_page(rec, clip, plots, scene)
    from robokit.record.atomic import write_text

    return write_text(out, html)
