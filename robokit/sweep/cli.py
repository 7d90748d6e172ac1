"""``robokit sweep``: many trials of one config over seeds and a grid of overrides, locally or on Ray.

Exit codes: 0 every trial ran and succeeded; 1 some trial failed, aborted or errored (or ``--max-trials`` left some
to run); 2 usage or config error (before any trial runs); 130 interrupted (finished trials are kept: re-run the
same command to resume; 143 for SIGTERM).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

EXAMPLE = """examples:
  robokit sweep configs/pick_place.toml --seeds 0:100
  robokit sweep configs/pick_place.toml --seeds 0:20 --set behaviour.speed=0.6,1.2 --out runs/speed
  robokit sweep sweeps/pick_place_speed.toml            # a sweep file: config, seeds, [grid], metrics
  robokit sweep configs/sort_robot.toml --seeds 0:500 --backend ray --address auto
"""


def add_sweep_command(sub: Any) -> None:
    """Add ``sweep`` to the CLI's subparsers."""
    p = sub.add_parser("sweep", help="run many trials (seeds x a grid of overrides), locally or on a Ray cluster",
                       epilog=EXAMPLE, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("config", help="a robokit config (.toml), or a sweep file (a TOML with a 'config' key)")
    p.add_argument("--seeds", metavar="A:B", help="seeds A..B-1, as a Python range (default 0:1, or the file's)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=V1,V2",
                   help="a dotted config key and its values (several values: a grid axis); repeatable")
    p.add_argument("--metrics", metavar="A,B", help="result figures to aggregate (default: every numeric one)")
    p.add_argument("--plugin", dest="plugins", action="append", default=[], metavar="MODULE",
                   help="an importable module registered as a plugin in every worker; repeatable")
    p.add_argument("--workers", type=int, metavar="N", help="local worker processes (default: CPU count)")
    p.add_argument("--out", metavar="DIR", help="output folder (default: sweeps/<config name>)")
    p.add_argument("--backend", choices=("local", "ray"), default="local")
    p.add_argument("--address", metavar="HOST:PORT|auto", help="Ray cluster to use (default: a private local Ray)")
    p.add_argument("--trial-timeout", type=float, metavar="S", help="wall seconds a trial may take (then: error)")
    p.add_argument("--max-trials", type=int, metavar="N", help="run at most N trials now (re-run to continue)")
    p.add_argument("--junit", metavar="FILE", help="write JUnit XML, one test case per trial")
    p.add_argument("--plot", metavar="FIGURE", help="figure whose distribution is plotted (default: the first)")
    p.add_argument("--report-url", metavar="URL", help="post every trial's result (the http reporter, outbox)")
    p.add_argument("--student", help="override report.student")
    p.add_argument("--project", help="override report.project")
    p.add_argument("--new-out", action="store_true",
                   help="when --out holds a sweep whose inputs changed, start a new folder beside it (DIR-2 ...)")
    p.add_argument("--keep", choices=("failed", "all", "none"), default="failed",
                   help="keep the run record (result, trace, poses) of these trials in DIR/runs/ (default: failed)")
    p.add_argument("--quiet", action="store_true", help="no progress and no summary table")
    p.set_defaults(func=cmd_sweep)


def _spec(args: argparse.Namespace) -> tuple[Any, dict[str, Any]]:
    from robokit.config import read_toml
    from robokit.sweep.spec import SweepSpec, load_sweep_file, parse_seeds, parse_set, tidy

    path = Path(args.config)
    raw = read_toml(path)
    if "config" in raw and isinstance(raw["config"], str):
        spec, options = load_sweep_file(path)
    else:
        spec, options = SweepSpec(config=tidy(path), seeds=range(0, 1)), {}
    grid, fixed = parse_set(args.sets)
    overlap = (set(grid) | set(fixed)) & (set(spec.grid) | set(spec.fixed))
    grid = {**{k: v for k, v in spec.grid.items() if k not in overlap}, **grid}
    fixed = {**{k: v for k, v in spec.fixed.items() if k not in overlap}, **fixed}
    metrics = tuple(m.strip() for m in args.metrics.split(",") if m.strip()) if args.metrics else spec.metrics
    spec = SweepSpec(spec.config, parse_seeds(args.seeds) if args.seeds else spec.seeds, grid, fixed, metrics,
                     tuple(dict.fromkeys([*spec.plugins, *args.plugins])), spec.sweep_file)
    return spec, options


def cmd_sweep(args: argparse.Namespace) -> int:
    """Run the sweep, print the summary table, return the exit code."""
    from robokit.errors import UserError
    from robokit.sweep.engine import SweepOptions, run_sweep
    from robokit.sweep.spec import tidy
    from robokit.sweep.summary import to_markdown

    spec, file_opts = _spec(args)
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers: expected at least 1, got {args.workers}")
    if args.trial_timeout is not None and args.trial_timeout <= 0:
        raise UserError(f"--trial-timeout: expected seconds > 0, got {args.trial_timeout}")
    out = tidy(args.out or file_opts.get("out") or Path("sweeps") / spec.config.stem)
    opts = SweepOptions(
        out=out, backend=args.backend, workers=args.workers or file_opts.get("workers"), address=args.address,
        trial_timeout=args.trial_timeout or file_opts.get("trial_timeout"), max_trials=args.max_trials,
        report_url=args.report_url, student=args.student, project=args.project,
        junit=Path(args.junit) if args.junit else None, plot=args.plot or file_opts.get("plot"),
        new_out=args.new_out, keep=args.keep, progress=None if args.quiet else sys.stdout,
    )
    from robokit.process.interrupts import StopGuard

    with StopGuard.ensure() as guard, guard.immediate():  # SIGINT / SIGTERM stop the sweep at once
        run = run_sweep(spec, opts)
    if run.out is not None and run.out != out:
        print(f"robokit: {out} holds a sweep with other inputs: this one is in {run.out}", file=sys.stderr)
        out = run.out
    if not args.quiet:
        print(to_markdown(run.summary), end="")
        print(f"trials: {out / 'trials.jsonl'}; summary: {out / 'summary.md'}"
              + (f"; ran {run.ran}, {run.skipped} already done" if run.skipped else ""))
    if run.interrupted:
        print(f"robokit: interrupted ({guard.signal or 'SIGINT'}): {len(run.rows)} trials kept; re-run the same "
              "command to resume", file=sys.stderr)
        return guard.exit_code
    if run.remaining:
        print(f"robokit: {run.remaining} trials still to run; re-run the same command to continue", file=sys.stderr)
    return 0 if run.all_succeeded else 1

