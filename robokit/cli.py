"""The ``robokit`` command. Heavy imports (pybullet, cv2) happen only inside the commands that need them.

Exit codes:

- 0: succeeded;
- 1: the behaviour failed or was aborted (e.g. ``max_time`` reached); a sweep with a failed or errored trial;
- 2: usage or config error (nothing ran);
- 3: a plugin (or robokit itself) raised (outcome ``error``);
- 4: the result could be neither delivered nor stored;
- 5: the server refused the result (kept; ``robokit outbox retry``);
- 6: the run succeeded and its result was kept, but its record (trace, pose log) or an output asked for (``--video``;
  ``robokit video / view / export``'s file) could not be written in full (a full disk, a file-size limit): each
  failure is a one-line warning naming the file and the reason, and an output not made leaves nothing under its name;
- 130: interrupted by SIGINT (Ctrl-C), 143: by SIGTERM, at any moment from the console script's first instruction
  (:mod:`robokit.entry`) to exit (one line on stderr;
  whatever result exists is kept: a signal during start-up gives an ``aborted`` result with no ticks, one during
  the loop stops at a tick boundary, one after the loop keeps the result as it was).

No input gives a Python traceback: user errors are one line; anything unexpected is one line naming what raised and
where, plus the path of a file with the full traceback. ``--debug`` (anywhere on the command line, or
``ROBOKIT_DEBUG=1``) prints the traceback too.
"""

from __future__ import annotations

import gc
import json
import math
import os
import sys
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, NoReturn

from robokit import __version__
from robokit.errors import PluginError, UserError
from robokit.plugin_api.plugins import PluginLoadWarning
from robokit.process.crash import describe, one_line, traceback_text, where_raised, write_traceback

if TYPE_CHECKING:
    import argparse

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_PLUGIN, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
EXIT_RECORD_INCOMPLETE = 6


def _finite_float(text: str) -> float:
    import argparse  # only to refuse the value: argparse then reports it

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive, finite number of seconds, got {text!r}")
    return value


def _parser(command: str | None = None) -> argparse.ArgumentParser:
    """The whole command line; with ``command="run"`` only ``run``'s sub-parser (what ``robokit run ...`` parses:
    building the other fifteen commands' options costs more than the parse itself)."""
    import argparse

    class _Parser(argparse.ArgumentParser):
        """An argument parser whose usage errors are one line (exit 2), naming the command's ``--help``."""

        def error(self, message: str) -> NoReturn:
            self.exit(EXIT_USAGE, f"robokit: error: {message} (see: {self.prog} --help)\n")

    parser = _Parser(prog="robokit", description="Run PyBullet robots from TOML configs.")
    parser.add_argument("--version", action="version", version=f"robokit {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="show full tracebacks (also accepted after the command; env ROBOKIT_DEBUG=1)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    _add_run_command(sub)
    if command != "run":
        _add_other_commands(sub)
    return parser


_RUN_OPTIONS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("--gui", {"action": "store_true", "help": "open the PyBullet GUI (paced to real time)"}),
    ("--seed", {"type": int, "help": "override world.seed"}),
    ("--engine", {"choices": ("pybullet", "mujoco"), "help": "override world.engine (mujoco: robokit[mujoco])"}),
    ("--max-time", {"type": _finite_float, "metavar": "S", "help": "override world.max_time (sim seconds)"}),
    ("--max-wall", {"type": _finite_float, "metavar": "S",
                    "help": "override world.max_wall_time: end the run (aborted) after S wall-clock seconds"}),
    ("--json", {"action": "store_true", "help": "print the RunResult JSON alone on stdout"}),
    ("--trace", {"metavar": "FILE", "help": "write state transitions and events as JSON lines"}),
    ("--quiet", {"action": "store_true", "help": "print nothing but errors (and --json output)"}),
    ("--student", {"help": "override report.student"}),
    ("--project", {"help": "override report.project"}),
    ("--report-url", {"metavar": "URL", "help": "post the result to this URL (the http reporter; the token is "
                                                "read from $ROBOKIT_TOKEN when that is set)"}),
    ("--token-env", {"metavar": "NAME", "help": "read the bearer token from this environment variable "
                                                "(report.http.token_env; default ROBOKIT_TOKEN when set)"}),
    ("--set", {"dest": "sets", "action": "append", "default": [], "metavar": "KEY=VALUE",
               "help": "override a dotted config key, as robokit sweep does (e.g. report.http.upload_artifacts=true);"
                       " repeatable"}),
    ("--gui-hold", {"action": "store_true", "help": "with --gui: keep the window open after the run"}),
    ("--pose-hz", {"type": float, "metavar": "HZ",
                   "help": "pose log rate, sim Hz (default [record] pose_hz = 30; 0 = none)"}),
    ("--no-record", {"action": "store_true", "help": "keep only result.json, no trace or pose log"}),
    ("--save-frames", {"action": "store_true", "help": "cameras save the frames they render as PNGs (RGB, depth, "
                                                       "segmentation) in the run folder"}),
    ("--live", {"action": "store_true", "help": "watch and drive the run in a browser: serve a live page (URL "
                                               "printed), paced to real time (docs/live.md)"}),
    ("--live-host", {"metavar": "HOST", "help": "with --live: bind HOST instead of 127.0.0.1 (the URL then carries "
                                                "a token)"}),
    ("--live-port", {"type": int, "default": 8765, "metavar": "PORT",
                     "help": "with --live: the page's port (default 8765; 0 = any free port)"}),
    ("--live-foxglove", {"type": int, "metavar": "PORT", "help": "with --live: also serve the Foxglove WebSocket "
                                                                 "protocol on PORT (robokit[foxglove])"}),
    ("--live-sensors", {"metavar": "A,B", "help": "with --live: show these sensors' readings from the start (the "
                                                  "page picks more)"}),
    ("--video", {"metavar": "FILE", "help": "render an MP4 of the run right after it, before the result is sent "
                                            "(robokit video)"}),
)
"""``robokit run``'s options."""


def _add_run_command(sub: Any) -> None:
    run = sub.add_parser("run", help="run a config until its behaviour ends")
    run.add_argument("config", help="path to a TOML config")
    for name, options in _RUN_OPTIONS:
        run.add_argument(name, **options)
    run.set_defaults(func=cmd_run)


def _add_other_commands(sub: Any) -> None:
    val = sub.add_parser("validate", help="check a config, its URDFs and named joints/links, without running")
    val.add_argument("config")
    val.add_argument("--engine", choices=("pybullet", "mujoco"), help="override world.engine")
    val.set_defaults(func=cmd_validate)

    plug = sub.add_parser("plugins", help="list every registered plugin type")
    plug.add_argument("--json", action="store_true")
    plug.set_defaults(func=cmd_plugins)

    ins = sub.add_parser("inspect", help="print a URDF's joint table (lesson 02)")
    ins.add_argument("urdf", help="a pybullet_data name (e.g. r2d2.urdf) or a path")
    ins.add_argument("--json", action="store_true")
    ins.set_defaults(func=cmd_inspect)

    graph = sub.add_parser("graph", help="print a behaviour's state machine, or what a config composes, as Mermaid")
    graph.add_argument("behaviour", help="a behaviour type name (e.g. sort) or a config file (e.g. configs/x.toml)")
    graph.set_defaults(func=cmd_graph)

    lint = sub.add_parser("lint", help="check plugin code for wall-clock reads, sleeps and global random generators")
    lint.add_argument("paths", nargs="+", metavar="PATH", help="Python files or folders")
    lint.set_defaults(func=cmd_lint)
    _add_extra_commands(sub)


def _add_extra_commands(sub: Any) -> None:
    """Commands that live in their own modules (kept out of the import path of ``--help``)."""
    try:
        from robokit.report.outbox_cli import add_outbox_command
    except ImportError:
        return
    add_outbox_command(sub)
    from robokit.report.artifact_upload import add_upload_command
    from robokit.report.submit import add_submit_command
    from robokit.server.cli import add_server_commands  # no Django import until `serve` / `manage` runs

    add_server_commands(sub)
    add_upload_command(sub)
    add_submit_command(sub)
    from robokit.record.cli import add_record_commands

    add_record_commands(sub)
    from robokit.sweep.cli import add_sweep_command

    add_sweep_command(sub)
    from robokit.robot.cli import add_robot_command

    add_robot_command(sub)


def _overrides(args: argparse.Namespace) -> dict[str, Any]:
    sets = getattr(args, "sets", None)
    out: dict[str, Any] = _set_overrides(sets) if sets else {}
    if getattr(args, "seed", None) is not None:
        out["world.seed"] = args.seed
    if getattr(args, "engine", None) is not None:
        out["world.engine"] = args.engine
    if getattr(args, "student", None) is not None:
        out["report.student"] = args.student
    if getattr(args, "project", None) is not None:
        out["report.project"] = args.project
    if getattr(args, "report_url", None) is not None:
        out["report.http.url"] = args.report_url
    if getattr(args, "max_wall", None) is not None:
        out["world.max_wall_time"] = args.max_wall
    if getattr(args, "token_env", None) is not None:
        out["report.http.token_env"] = args.token_env
    return out


def _set_overrides(items: list[str]) -> dict[str, Any]:
    """``--set KEY=VALUE`` options, read by robokit sweep's parser (one value each: a run is one cell)."""
    from robokit.sweep.spec import parse_set

    grid, fixed = parse_set(items)
    if grid:
        key = next(iter(grid))
        raise UserError(f"--set {key}: robokit run takes one value per key (several values make a grid: "
                        f"robokit sweep CONFIG --set {key}=...)")
    return fixed


def _load(args: argparse.Namespace) -> tuple[Any, Any]:
    from robokit.plugin_api.plugins import load_plugins

    plugins = load_plugins()  # before robokit.config builds its models: pydantic's plugin scan is answered then
    from robokit.config import load_config

    return plugins, load_config(args.config, plugins, _overrides(args))


_run_started = False
"""``cmd_run`` began: from then on it keeps the result itself (an ``aborted`` one if a signal ends start-up)."""
_run_called = False
"""``cmd_run`` handed the run to :func:`robokit.runner.run_config`, which keeps the result from then on."""


def cmd_run(args: argparse.Namespace) -> int:
    """``robokit run``: build, run, report; print a summary (or the RunResult JSON with ``--json``)."""
    global _run_started
    guard = None
    try:  # set inside the try: a signal before it is main()'s to handle, one after is handled below
        _run_started = True
        if args.video:  # before anything is simulated: the video needs imageio-ffmpeg
            from robokit.extras import require

            require("video", "robokit run --video", ("imageio_ffmpeg",))
        from robokit.process.interrupts import StopGuard

        guard = StopGuard.current()
        plugins, cfg = _load(args)  # first: robokit.runner imports robokit.config, see _load
        from robokit.runner import run_config
    except BaseException as exc:  # a signal broke into start-up (imports, plugins): keep what can be kept
        if isinstance(exc, KeyboardInterrupt) or (guard is not None and guard.signalled):
            return _interrupted_before_config(args, guard.signal if guard is not None else None)
        raise
    try:
        return _run_loaded(args, plugins, cfg, run_config)
    except KeyboardInterrupt as exc:
        if _run_called and not getattr(exc, "robokit_before_run", False):  # the run keeps its own result
            raise
        return _interrupted_before_config(args, guard.signal if guard is not None else None)


def _live_view(args: argparse.Namespace, plugins: Any, cfg: Any) -> Any:
    """``--live``: the live view, registered as a plugin of this run (it starts serving when the run starts)."""
    if not args.live:
        given = [o for o, v in (("--live-host", args.live_host), ("--live-foxglove", args.live_foxglove),
                                ("--live-sensors", args.live_sensors)) if v is not None]
        if given:
            raise UserError(f"{given[0]} needs --live")
        return None
    from robokit.live import LiveView

    sensors = tuple(n.strip() for n in (args.live_sensors or "").split(",") if n.strip())
    names = [spec.name for spec in (*cfg.sensors, *cfg.actuators)]
    unknown = [n for n in sensors if n not in names]
    if unknown:
        raise UserError(f"--live-sensors: no sensor or actuator {unknown[0]!r} in {cfg.source}; it has "
                        f"{', '.join(names) or '(none)'}")
    view = LiveView(args.live_host or "127.0.0.1", args.live_port, foxglove_port=args.live_foxglove, sensors=sensors)
    plugins.pm.register(view, name="robokit-live")
    return view


def _run_loaded(args: argparse.Namespace, plugins: Any, cfg: Any, run_config: Any) -> int:
    """``robokit run`` once its config is loaded: a signal before :func:`robokit.runner.run_config` takes over
    reaches :func:`cmd_run` (which keeps an ``aborted`` result); one after is the run's own."""
    _end_startup_gc_pause()
    gui = bool(args.gui or cfg.world.gui)
    if gui:
        from robokit.core.gui import check_display

        check_display(f"robokit run {args.config} --gui")
    elif args.gui_hold:
        raise UserError("--gui-hold needs --gui (there is no window to hold)")
    shown: list[Any] = []

    def show(out: Any) -> None:  # the outcome, as soon as the result is kept (before --gui-hold holds)
        if not shown:
            shown.append(out)
            _show_outcome(args, out, cfg)

    hold = None
    if args.gui_hold:
        from robokit.core.gui import hold as hold_window

        def hold(sim: Any, out: Any) -> None:
            show(out)
            _hold_window(hold_window, sim.world)

    live = _live_view(args, plugins, cfg)
    trace = _open_trace(args.trace) if args.trace else None
    video = _video_before_send(cfg, args) if args.video else None
    global _run_called
    try:
        _run_called = True
        out = run_config(cfg, plugins, gui=True if args.gui else None, max_time=args.max_time, trace=trace,
                         record=not args.no_record, pose_hz=args.pose_hz, save_frames=args.save_frames,
                         after_run=hold, on_problem=None if args.quiet else _warn_problem, before_send=video)
    finally:
        if live is not None:
            live.close()
        if trace is not None:
            try:
                trace.close()
            except OSError as exc:  # already reported by the trace writer when a record failed
                print(f"robokit: warning: --trace {args.trace}: {exc.strerror or exc}", file=sys.stderr)
    if shown:  # printed before the window was held: only what happened since
        for failure in out.record_failures[len(shown[0].record_failures):]:
            print(f"robokit: warning: {failure}", file=sys.stderr)
    else:
        show(out)
    if not args.quiet:
        _frames_note(cfg, out, args)
    refused = _refused(out)
    if out.interrupted:
        if not args.quiet:
            print(f"robokit: interrupted ({out.signal or 'SIGINT'}); the result was kept (see above)",
                  file=sys.stderr)
    elif out.before_send_error is not None:  # the video failed; the result was sent all the same
        raise out.before_send_error
    return refused if refused is not None and out.exit_code not in (130, 143, 4) else out.exit_code


def _video_before_send(cfg: Any, args: argparse.Namespace) -> Any:
    """``--video FILE``: render the video before the result is sent, so ``upload_artifacts`` uploads it too."""
    from robokit.record.cli import video_after_run

    def render(out: Any) -> None:
        if out.result.interrupted:
            return
        try:
            failure = video_after_run(cfg, out.result.run_id, args.video, quiet=args.quiet)
        except KeyboardInterrupt as exc:
            out.record_failures.append(getattr(exc, "robokit_detail", f"video {args.video} not written"))
            raise
        if failure is not None:
            out.record_failures.append(failure)
    return render


def _refused(out: Any) -> int | None:
    """A report the server refused: one loud line on stderr (what to change) and the exit code to end with."""
    from robokit.report.reporting import EXIT_REFUSED, Refused

    refusals = [(name, d) for name, d in out.deliveries if isinstance(d, Refused)]
    for name, d in refusals:
        print(f"robokit: error: report[{name}] {d.line()}", file=sys.stderr)
    return EXIT_REFUSED if refusals else None


def _frames_note(cfg: Any, out: Any, args: argparse.Namespace) -> None:
    """With ``--save-frames`` (or a camera's ``save``): one line saying where the frames went."""
    from robokit.config import results_root
    from robokit.record.results import frames_note

    folder = None if args.no_record else results_root(cfg) / out.result.run_id
    note = frames_note(folder, args.save_frames or cfg.record.save_frames)
    if note:
        print(note, file=sys.stderr if args.json else sys.stdout)


def _interrupted_before_command(argv: list[str]) -> int:
    """A signal ended the command before it began (imports, parsing the command line): for ``robokit run CONFIG``
    keep an ``aborted`` result all the same, as :func:`_interrupted_before_config` does."""
    config, seed = _run_arguments(argv)
    if _run_started or config is None or not os.path.isfile(config):
        return _interrupted(None)
    from robokit.process.interrupts import StopGuard

    guard = StopGuard.current()
    import argparse

    args = argparse.Namespace(config=config, seed=seed, json="--json" in argv)
    return _interrupted_before_config(args, guard.signal if guard is not None else None)


def _run_arguments(argv: list[str]) -> tuple[str | None, int | None]:
    """``robokit run``'s config and ``--seed`` read from the raw command line (no parser: it may be what a signal
    broke into); ``(None, None)`` for another command."""
    if not argv or argv[0] != "run":
        return None, None
    takes_value = {name for name, options in _RUN_OPTIONS if "action" not in options}
    config, seed, i = None, None, 1
    while i < len(argv):
        arg = argv[i]
        name = arg.split("=", 1)[0]
        if arg.startswith("--") and name in takes_value and "=" not in arg:
            if name == "--seed" and i + 1 < len(argv) and argv[i + 1].lstrip("-").isdigit():
                seed = int(argv[i + 1])
            i += 2
            continue
        if config is None and not arg.startswith("-"):
            config = arg
        i += 1
    return config, seed


def _interrupted_before_config(args: argparse.Namespace, signal_name: str | None) -> int:
    """A signal ended start-up before the config was loaded: keep an ``aborted`` result.json all the same, written
    with the standard library alone (whatever was being imported is left alone)."""
    from robokit.core.result import early_result, write_early_result

    if signal_name is None:
        from robokit.process.interrupts import StopGuard

        guard = StopGuard.current()
        signal_name = guard.signal if guard is not None else None
    path, payload = early_result(args.config, signal_name or "SIGINT", seed=args.seed)
    try:
        write_early_result(path, payload)
        kept = f"the result was kept in {path}"
    except OSError as err:
        kept = f"no result kept: {path}: {err.strerror or err}"
    if args.json:
        print(json.dumps(payload, indent=2), flush=True)
    return _interrupted(f"during start-up, before the config was loaded; {kept}")


def _show_outcome(args: argparse.Namespace, out: Any, cfg: Any) -> None:
    """Print the result (``--json``) and the summary; report an ``error`` outcome's traceback file."""
    from robokit.runner import summary

    if args.json:
        print(json.dumps(out.result.to_dict(), indent=2), flush=True)
    if not args.quiet:
        print(summary(out), file=sys.stderr if args.json else sys.stdout, flush=True)
    if out.error is not None:
        _report_error(args, out, cfg)


def _hold_window(hold_window: Any, world: Any) -> None:
    """Hold the GUI window; Ctrl-C there only closes it (the run's exit code stays), SIGTERM still ends robokit."""
    from robokit.process.interrupts import StopGuard

    guard = StopGuard.current()
    if guard is None:
        hold_window(world)
        return
    with guard.absorbing(signals=("SIGINT",)):
        hold_window(world)


def _report_error(args: argparse.Namespace, out: Any, cfg: Any) -> None:
    """A run that ended in ``error``: the full traceback goes to the run folder (and stderr with --debug)."""
    from robokit.config import results_root

    assert out.error is not None
    text = traceback_text(out.error)
    path = write_traceback(text, results_root(cfg) / out.result.run_id)
    if getattr(args, "debug", False):
        print(text, file=sys.stderr, end="")
    if path is not None and not args.quiet:
        print(f"robokit: full traceback: {path}" + ("" if args.debug else " (or run with --debug)"),
              file=sys.stderr)


def _open_trace(path: str) -> Any:
    """Open the ``--trace`` file for writing before anything runs; a path that cannot be written is a usage error."""
    if os.path.isdir(path):
        raise UserError(f"--trace {path}: is a folder; give a file name, e.g. {os.path.join(path, 'trace.jsonl')}")
    parent = os.path.dirname(path) or "."
    if not os.path.isdir(parent):
        raise UserError(f"--trace {path}: the folder {parent} does not exist")
    try:
        # line-buffered: a write that fails (a full disk) fails at the record it was writing, not at close
        return open(path, "w", encoding="utf-8", buffering=1)  # noqa: SIM115 - closed by cmd_run
    except OSError as exc:
        raise UserError(f"--trace {path}: cannot write: {exc.strerror or exc}") from None


def _warn_problem(problem: Exception) -> None:
    print(f"robokit: warning: {problem}", file=sys.stderr, flush=True)


def cmd_validate(args: argparse.Namespace) -> int:
    """``robokit validate``: validate the config, set every component up in a DIRECT world and run every
    preflight check (reach, camera view, overlaps, ...), without stepping. Each problem is one line; exit 2."""
    from robokit.core.simulation import Simulation

    plugins, cfg = _load(args)
    with Simulation(cfg, plugins, gui=False) as sim:
        n_bodies = len(sim.world.body_names)
        problems = sim.preflight()
    from robokit.robot.check import config_problems  # every robot's own description (robokit robot check)

    problems += config_problems(cfg)
    for problem in problems:
        print(f"robokit: error: {problem}", file=sys.stderr)
    if problems:
        return EXIT_USAGE
    parts = [f"{n_bodies} bodies", f"{len(cfg.sensors)} sensors", f"{len(cfg.actuators)} actuators",
             f"behaviour {cfg.behaviour.type if cfg.behaviour else '(none)'}"]
    print(f"{args.config}: ok ({', '.join(parts)})")
    return EXIT_OK


def cmd_plugins(args: argparse.Namespace) -> int:
    """``robokit plugins``: every registered type with kind, distribution, version and description."""
    from robokit.plugin_api.plugins import load_plugins

    plugins = load_plugins()
    rows = [
        {"kind": t.kind, "type": plugins.listed_name(t),
         "distribution": t.distribution, "version": t.version,
         "description": t.description}
        for t in plugins.all_types()
    ]
    if args.json:
        print(json.dumps({"types": rows, "clashes": plugins.clashes(), "broken": plugins.broken}, indent=2))
        return EXIT_OK
    width = max((len(r["type"]) for r in rows), default=4)
    origins = [f"{r['distribution']} {r['version']}".strip() for r in rows]
    owidth = max((len(o) for o in origins), default=8)
    for r, origin in zip(rows, origins, strict=True):
        print(f"{r['kind']:<10} {r['type']:<{width}}  {origin:<{owidth}}  {r['description']}")
    for line in plugins.clashes():
        print(f"clash: {line}")
    for label, why in plugins.broken.items():
        print(f"not loaded: {label}: {why}")
    return EXIT_OK


def cmd_inspect(args: argparse.Namespace) -> int:
    """``robokit inspect``: lesson 02's joint table of a URDF."""
    from robokit.core.world import World
    from robokit.robot.cli import inspect_links, inspect_path, print_links

    urdf = inspect_path(args.urdf)  # a xacro file is expanded first
    with World.create() as world:
        world.load_urdf("robot", urdf, fixed_base=True)
        joints = world.joints("robot")
        base = world.base_link_name("robot")
        links = inspect_links(world, urdf)
    if args.json:
        print(json.dumps({"urdf": args.urdf, "base_link": base, "joints": [j.__dict__ for j in joints],
                          "links": links}, indent=2))
        return EXIT_OK
    print(f"{args.urdf}: base link {base!r}, {len(joints)} joints")
    header = ("idx", "name", "type", "lower", "upper", "max_force", "max_vel", "child link")
    print("{:>3}  {:<28} {:<10} {:>9} {:>9} {:>9} {:>8}  {}".format(*header))
    for j in joints:
        print(f"{j.index:>3}  {j.name:<28} {j.type:<10} {j.lower:>9.3f} {j.upper:>9.3f} {j.max_force:>9.1f} "
              f"{j.max_velocity:>8.2f}  {j.child_link}")
    print_links(links)
    return EXIT_OK


def cmd_graph(args: argparse.Namespace) -> int:
    """``robokit graph``: a behaviour's state machine, or a config's task, sequence and monitors, as Mermaid."""
    from pathlib import Path

    from robokit.plugin_api.plugins import load_plugins

    if args.behaviour.endswith(".toml") or Path(args.behaviour).is_file():
        from robokit.config import load_config
        from robokit.core.compose import config_mermaid

        plugins = load_plugins()
        print(config_mermaid(load_config(args.behaviour, plugins), plugins), end="")
        return EXIT_OK
    ptype = load_plugins().get("behaviour", args.behaviour)
    mermaid = getattr(ptype.cls, "mermaid", None)
    if mermaid is None:
        raise UserError(f"behaviour {args.behaviour!r} is not a state machine (it has no mermaid())")
    print(mermaid(), end="")
    return EXIT_OK


def cmd_lint(args: argparse.Namespace) -> int:
    """``robokit lint``: one line per finding (file:line:col: code message), exit 1; clean: what was checked."""
    from robokit.checks.lint import lint_report

    try:
        lines, found = lint_report(args.paths)
    except (FileNotFoundError, SyntaxError) as exc:
        raise UserError(str(exc)) from None
    print("\n".join(lines))
    return EXIT_FAILED if found else EXIT_OK


CAPTURED_COMMANDS = frozenset({"run", "validate", "inspect", "plugins", "graph", "video", "plot", "view", "results",
                               "export"})
"""Commands whose pybullet C output is captured and summarised (they run pybullet in this process)."""


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``robokit`` console script; returns the exit code.

    For the commands in :data:`CAPTURED_COMMANDS`, C-level output on file descriptors 1 and 2 (pybullet's
    b3Warning lines, build banner, GUI chatter) never reaches the terminal as is: it is captured for the whole
    command and summarised in one line on stderr (nothing with ``--quiet``).
    """
    global _run_started, _run_called
    _run_started = _run_called = False
    own_process = argv is None  # the console script: this process is robokit's own
    guard = None
    if own_process:  # first of all: a signal from here on is handled (130 / 143, one line), never a traceback
        from robokit.process.interrupts import StopGuard

        guard = StopGuard.for_process()
        _one_blas_thread()
    argv = list(sys.argv[1:] if argv is None else argv)
    if own_process and argv[:1] and argv[0] in GC_PAUSED_COMMANDS:
        _pause_gc_for_startup()
    code = EXIT_INTERRUPTED
    try:
        if guard is not None:
            _deliver_noted_signals()
        code = _main(argv)
    except KeyboardInterrupt:  # a signal between the guard's phases, or before any command was chosen
        code = _interrupted_before_command(argv)
    finally:
        _end_startup_gc_pause()
    return guard.closing(code) if guard is not None else code


def _deliver_noted_signals() -> None:
    """Signals the console script's entry module (:mod:`robokit.entry`) noted before robokit's guard was installed
    are delivered again, now to the guard: handled as any signal during start-up."""
    entry = sys.modules.get("robokit.entry")
    if entry is None:
        return
    import signal

    for signum in entry.noted():
        signal.raise_signal(signum)


def _interrupted(detail: str | None) -> int:
    """Say in one line that a signal ended the command; the exit code it asks for (130 / 143)."""
    from robokit.process.interrupts import StopGuard, exit_code_for

    guard = StopGuard.current()
    name = guard.signal if guard is not None and guard.signal else "SIGINT"

    print(f"robokit: interrupted ({name})" + (f"; {detail}" if detail else ""), file=sys.stderr, flush=True)
    return exit_code_for(name)


def _main(argv: list[str]) -> int:
    """Parse ``argv`` and run the command (see :func:`main`)."""
    from robokit.process.crash import debug_from_env
    from robokit.process.quiet import capture_c_stdout

    cut = argv.index("--") if "--" in argv else len(argv)
    debug = debug_from_env() or "--debug" in argv[:cut]
    argv = [a for a in argv[:cut] if a != "--debug"] + argv[cut:]
    try:
        args = _parser(argv[0] if argv else None).parse_args(argv)
    except KeyboardInterrupt:
        return _interrupted_before_command(argv)
    args.debug = debug
    from robokit.process.interrupts import StopGuard

    with warnings.catch_warnings(), StopGuard.ensure():  # restores the caller's warning settings and signals
        warnings.simplefilter("always", PluginLoadWarning)
        warnings.simplefilter("always", UserWarning)
        warnings.showwarning = _show_warning
        if args.command not in CAPTURED_COMMANDS:  # e.g. serve: its child processes write to the real streams
            return _dispatch(args)
        with capture_c_stdout() as captured:
            code = _dispatch(args)
    note = captured.summary()
    if note and not getattr(args, "quiet", False):
        print(note, file=sys.stderr)
    return code


GC_PAUSED_COMMANDS = frozenset({"run", "validate", "plugins", "graph", "inspect"})
"""Commands whose start-up runs with the cyclic collector paused (see :func:`_pause_gc_for_startup`): ``run``
until its first tick; the others, short and bounded, until they end."""

_startup_gc_paused = False


def _pause_gc_for_startup() -> None:
    """Switch the cyclic garbage collector off while ``robokit run`` starts up (see :func:`_end_startup_gc_pause`).

    Start-up allocates some 60,000 long-lived objects (numpy, pybullet, pydantic and the models, the plugins) and
    almost no cyclic garbage (~700 objects): the collector passes that would run meanwhile find nothing.
    """
    global _startup_gc_paused
    if gc.isenabled():
        gc.disable()
        _startup_gc_paused = True


def _end_startup_gc_pause() -> None:
    """Move everything start-up allocated to the collector's permanent generation and switch it back on, before
    the first tick: the run's own garbage is collected as usual, and later passes (and the one at exit) no longer
    walk the start-up objects. ``robokit run`` of a trivial config: about a sixth less process time."""
    global _startup_gc_paused
    if _startup_gc_paused:
        _startup_gc_paused = False
        gc.freeze()
        gc.enable()


def _one_blas_thread() -> None:
    """Use one OpenBLAS thread unless ``OPENBLAS_NUM_THREADS`` says otherwise (set before numpy is imported).

    robokit's linear algebra is small (7x7 Jacobians, 360-ray scans), below the size OpenBLAS threads; its worker
    thread only costs: after numpy's import it spins for ~0.1 s of CPU before it sleeps, a third of a trivial
    run's process time (``benchmarks/startup.py``). Child processes (sweep workers) inherit the setting.
    """
    if "numpy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _show_warning(message: Warning | str, category: type[Warning], *_args: Any, **_kwargs: Any) -> None:
    print(f"robokit: warning: {message}", file=sys.stderr)


def _dispatch(args: argparse.Namespace) -> int:
    """Run the chosen command; every error becomes one line and an exit code (a traceback only with --debug)."""
    from robokit.process.interrupts import StopGuard

    guard = StopGuard.current()
    try:
        code: int = args.func(args)
        if guard is not None and guard.signalled and code != guard.exit_code:  # else the command said so itself
            return _interrupted(None)
    except KeyboardInterrupt as exc:
        return _interrupted(getattr(exc, "robokit_detail", None))
    except BaseException as exc:
        if guard is not None and guard.signalled:  # whatever a signal broke (a half-done import) is not a bug
            return _interrupted(f"stopped at {describe(exc)}" if not isinstance(exc, UserError) else None)
        return _dispatch_error(args, exc)
    return code


def _dispatch_error(args: argparse.Namespace, exc: BaseException) -> int:
    """One line and an exit code for what a command raised (anything but an Exception is raised on)."""
    if isinstance(exc, UserError):
        print(f"robokit: error: {one_line(exc, 2000)}", file=sys.stderr)
        return EXIT_USAGE
    from robokit.record.atomic import OutputFailed

    if isinstance(exc, OutputFailed):  # an output (a video, a page, an export) could not be made: nothing is left
        print(f"robokit: warning: {one_line(exc, 2000)}", file=sys.stderr)
        return EXIT_RECORD_INCOMPLETE
    if isinstance(exc, PluginError):
        _report_crash(args, exc, f"robokit: error: {one_line(exc, 2000)}")
        return EXIT_PLUGIN
    if isinstance(exc, BrokenPipeError):  # `robokit plugins | head`: the reader left; say nothing more
        sys.stderr.close()
        return EXIT_FAILED
    if not isinstance(exc, Exception):
        raise exc
    where = where_raised(exc)  # a bug: one line and a traceback file, never a bare traceback
    _report_crash(args, exc, f"robokit: internal error: {describe(exc)}" + (f" (at {where})" if where else ""))
    return EXIT_PLUGIN


def _report_crash(args: argparse.Namespace, exc: BaseException, line: str) -> None:
    """Print ``line``; write the full traceback to the run folder (or a temporary file) and say where."""
    text = traceback_text(exc)
    path = write_traceback(text, getattr(exc, "robokit_run_dir", None))
    if getattr(args, "debug", False):
        print(text, file=sys.stderr, end="")
    where = f"; full traceback: {path}" if path else ""
    print(f"{line}{where}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
