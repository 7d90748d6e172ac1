"""``robokit results | video | plot | view``: look at a run afterwards, from its record. Heavy imports stay inside."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from robokit.errors import UserError
from robokit.extras import require

RUN_HELP = "a run id, a prefix of one, 'last', or a run folder"


def add_record_commands(sub: Any) -> None:
    """Add the record commands to the ``robokit`` sub-command parser."""
    res = sub.add_parser("results", help="recent runs: list, show one, or the last one")
    rsub = res.add_subparsers(dest="results_command", metavar="ACTION")
    rsub.required = True
    lst = rsub.add_parser("list", help="recent runs: time, config, seed, outcome, headline figures")
    lst.add_argument("-n", type=int, default=20, help="how many (newest last; default 20)")
    _dir(lst)
    lst.set_defaults(func=cmd_results_list)
    show = rsub.add_parser("show", help="one run, readably (nested results as an indented tree)")
    show.add_argument("run", help=RUN_HELP)
    _dir(show)
    show.set_defaults(func=cmd_results_show)
    last = rsub.add_parser("last", help="the newest run, as 'show' prints it")
    last.add_argument("--path", action="store_true", help="print only its folder, e.g. ls \"$(robokit results last "
                      "--path)/frames\"")
    _dir(last)
    last.set_defaults(func=cmd_results_show, run="last")

    vid = sub.add_parser("video", help="render a run's record as an H.264 MP4 (needs the 'video' extra)")
    vid.add_argument("run", help=RUN_HELP)
    vid.add_argument("-o", "--output", metavar="FILE", help="MP4 to write (default: <run folder>/video.mp4)")
    vid.add_argument("--fps", type=float, help="frames per sim second (default: the pose log's rate)")
    vid.add_argument("--size", default="480x360", metavar="WxH", help="frame size in pixels (default 480x360: the "
                     "main job's video in ~15 s on two cores; 640x480 is sharper and ~1.4x slower)")
    vid.add_argument("--workers", type=int, metavar="N", help="render processes (default: one per core; 1 renders "
                     "in this process)")
    vid.add_argument("--view", metavar="NAME|EYE,TARGET", help="a named view (front, side, top, iso, or a camera "
                     "sensor's name) or 'ex,ey,ez,tx,ty,tz' (default: iso)")
    vid.add_argument("--renderer", choices=("auto", "pybullet", "mujoco"), default="auto",
                     help="the engine that draws the frames (default auto: the engine that ran the run; PyBullet, "
                     "with a note, when MuJoCo cannot render here)")
    still = vid.add_mutually_exclusive_group()
    still.add_argument("--time", metavar="S", help="write one PNG of the scene at sim time S seconds ('end': the "
                       "last moment) instead of a video (-o defaults to <run folder>/frame_<N>.png)")
    still.add_argument("--frame", type=_frame_number, metavar="N", help="write one PNG of video frame N instead of "
                       "a video (frames count from 0 at --fps, default the pose log's 30 a second; -1 is the last)")
    _dir(vid)
    vid.set_defaults(func=cmd_video)

    plot = sub.add_parser("plot", help="plots of a run: state timelines, map, heights, joints, lidar")
    plot.add_argument("run", help=RUN_HELP)
    plot.add_argument("-o", "--output", metavar="DIR", help="folder for the pictures (default: <run folder>/plots)")
    plot.add_argument("--format", choices=("png", "svg"), default="png")
    plot.add_argument("--scan-at", type=float, metavar="S", help="sim time of the polar lidar plot (default: the "
                      "middle of the run)")
    _dir(plot)
    plot.set_defaults(func=cmd_plot)

    view = sub.add_parser("view", help="one self-contained HTML page for a run (outcome, video, plots, diagrams)")
    view.add_argument("run", help=RUN_HELP)
    view.add_argument("-o", "--output", metavar="FILE", help="HTML file (default: <run folder>/index.html)")
    view.add_argument("--no-video", action="store_true", help="leave the video out (faster; smaller page)")
    view.add_argument("--no-replay", action="store_true", help="leave the interactive 3D replay out")
    _dir(view)
    view.set_defaults(func=cmd_view)

    exp = sub.add_parser("export", help="a run's record for Rerun (.rrd) or Foxglove (.mcap): poses, shapes, "
                         "scans, frames, states")
    exp.add_argument("run", help=RUN_HELP)
    exp.add_argument("--rerun", metavar="FILE", help="write a Rerun recording (needs the 'rerun' extra)")
    exp.add_argument("--mcap", metavar="FILE", help="write MCAP with Foxglove schemas (needs the 'rerun' extra)")
    _dir(exp)
    exp.set_defaults(func=cmd_export)


def _frame_number(text: str) -> int:
    """``--frame``'s value: a whole frame number (a sim time in seconds is ``--time``)."""
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a frame number such as 30 or -1, got {text!r} (for a sim time "
                                         f"in seconds: --time {text})") from None


def _dir(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--dir", metavar="DIR", help="the results folder (default: ./results)")


def _parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise UserError(f"--size: expected WxH in pixels, e.g. 640x480, got {text!r}") from None
    if not (16 <= w <= 3840 and 16 <= h <= 2160) or w % 2 or h % 2:
        raise UserError(f"--size: width and height must be even and between 16x16 and 3840x2160, got {text!r}")
    return w, h


def cmd_results_list(args: argparse.Namespace) -> int:
    from robokit.record.results import list_runs, where_note

    print(list_runs(args.dir, args.n))
    note = where_note(args.dir)
    if note:
        print(note, file=sys.stderr)
    return 0


def cmd_results_show(args: argparse.Namespace) -> int:
    from robokit.record.format import find_run
    from robokit.record.results import show_run

    rec = find_run(args.run, args.dir)
    print(rec.folder if getattr(args, "path", False) else show_run(rec))
    return 0


def cmd_video(args: argparse.Namespace) -> int:
    still = args.frame is not None or args.time is not None
    if not still:
        require("video", "robokit video", ("imageio_ffmpeg",))
    from robokit.record.format import find_run
    from robokit.record.video import choose_renderer, render_video

    size = _parse_size(args.size)
    rec = find_run(args.run, args.dir)
    if still:
        from robokit.record.video import render_still

        k = _still_frame(args, rec)
        engine, note = choose_renderer(rec, args.renderer)
        if note:
            print(f"robokit: note: {note}", file=sys.stderr)
        rate = args.fps or float(rec.header.get("pose_hz") or 30.0)
        out = Path(args.output) if args.output else rec.folder / f"frame_{k}.png"
        t = render_still(rec, out, at=k / rate, size=size, view=args.view, engine=engine)
        print(f"{out}: frame {k}, the scene at t = {t:.3f} s, {size[0]}x{size[1]}, drawn by {engine}")
        return 0
    out = Path(args.output) if args.output else rec.folder / "video.mp4"
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers must be at least 1, got {args.workers}")
    try:
        stats = render_video(rec, out, fps=args.fps, size=size, view=args.view, workers=args.workers,
                             progress=None, renderer=args.renderer)
    except KeyboardInterrupt as exc:
        exc.robokit_detail = f"{out} not written; its partial file was removed"  # type: ignore[attr-defined]
        raise
    if stats.note:
        print(f"robokit: note: {stats.note}", file=sys.stderr)
    print(f"{out}: {stats.frames} frames, {stats.width}x{stats.height}, {stats.fps:g} fps, H.264, drawn by "
          f"{stats.renderer} (rendered and encoded at {stats.render_fps:.1f} frames/s)")
    return 0


def _still_frame(args: argparse.Namespace, rec: Any) -> int:
    """The video frame ``--frame N`` or ``--time S`` asks for (0-based, at ``--fps``); out of range is one line."""
    from robokit.record.video import frame_indices

    rate = args.fps or float(rec.header.get("pose_hz") or 30.0)
    if rate <= 0:
        raise UserError(f"--fps must be positive, got {rate:g}")
    total = len(frame_indices(rec.poses["t"], rate))
    last = total - 1
    if args.frame is not None:
        k = args.frame + total if args.frame < 0 else args.frame
        if not 0 <= k <= last:
            raise UserError(f"--frame {args.frame}: this run's video has frames 0 to {last} ({rate:g} a second; "
                            f"-1 is the last)")
        return k
    text = str(args.time).strip().lower()
    if text == "end":
        return last
    try:
        seconds = float(text)
    except ValueError:
        raise UserError(f"--time: expected sim seconds or 'end', got {args.time!r}") from None
    end = last / rate
    if not 0 <= seconds <= end + 1e-9:
        raise UserError(f"--time {args.time}: this run's video lasts 0 to {end:.3f} s ('end' is the last moment)")
    return int(seconds * rate + 1e-6)


def cmd_plot(args: argparse.Namespace) -> int:
    require("video", "robokit plot", ("matplotlib",))
    from robokit.record.format import find_run
    from robokit.record.plots import make_plots

    rec = find_run(args.run, args.dir)
    out = Path(args.output) if args.output else rec.folder / "plots"
    for path in make_plots(rec, out, fmt=args.format, scan_at=args.scan_at):
        print(path)
    return 0


def cmd_view(args: argparse.Namespace) -> int:
    from robokit.record.format import find_run
    from robokit.record.page import find_video, write_page

    rec = find_run(args.run, args.dir)
    renders = not args.no_video and find_video(rec) is None and rec.has_poses
    require("video", "robokit view" + (" --no-video" if args.no_video else ""),
            ("matplotlib", "imageio_ffmpeg") if renders else ("matplotlib",))
    out = Path(args.output) if args.output else rec.folder / "index.html"
    try:
        write_page(rec, out, video=not args.no_video, replay=not args.no_replay)
    except KeyboardInterrupt as exc:
        exc.robokit_detail = f"{out} not written; no partial file was left"  # type: ignore[attr-defined]
        raise
    print(out)
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from robokit.record.export import export_mcap, export_rerun
    from robokit.record.format import find_run
    from robokit.record.replay import replay_of

    if not args.rerun and not args.mcap:
        raise UserError("robokit export: give --rerun FILE.rrd and/or --mcap FILE.mcap")
    if args.rerun:
        import os

        os.environ.setdefault("RUST_LOG", "off")  # before Rerun loads: its own log lines; a failure is said once
        require("rerun", "robokit export --rerun", ("rerun",))
    if args.mcap:
        require("rerun", "robokit export --mcap", ("mcap",))
    rec = find_run(args.run, args.dir)
    replay = replay_of(rec)
    for path, write in ((args.rerun, export_rerun), (args.mcap, export_mcap)):
        if path:
            counts = write(rec, Path(path), replay)
            print(f"{path}: " + ", ".join(f"{v} {k}" for k, v in counts.items()))
    return 0


def video_after_run(cfg: Any, run_id: str, output: str, *, quiet: bool = False) -> str | None:
    """``robokit run --video FILE``: render the run just finished. Returns None when the video was made, else one
    line naming the file and why it was not (a full disk; an interrupt, passed on after the line is noted in
    ``KeyboardInterrupt.robokit_detail``): the run's record failure, exit code 6."""
    from robokit.config import results_root
    from robokit.record.atomic import OutputFailed
    from robokit.record.format import RunRecord
    from robokit.record.video import render_video

    try:
        stats = render_video(RunRecord(results_root(cfg) / run_id), Path(output),
                             progress=None if not quiet else False)
    except OutputFailed as exc:
        return f"video {exc}"
    except KeyboardInterrupt as exc:
        exc.robokit_detail = f"video {output} not written; its partial file was removed"  # type: ignore[attr-defined]
        raise
    if not quiet:
        if stats.note:
            print(f"video: note: {stats.note}", file=sys.stderr)
        print(f"video: {output}: {stats.frames} frames at {stats.fps:g} fps, drawn by {stats.renderer}",
              file=sys.stderr)
    return None
