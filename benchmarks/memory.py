"""Memory over many runs in one process: does a sweep worker grow?

Each trial does what one ``robokit run`` does in-process: load the plugins, load and validate the config, build
the simulation (a fresh PyBullet client), run it for ``--max-time`` sim seconds, build the payload and store the
result with the local reporter (into a temporary folder), close everything. The resident set size (RSS, from
``/proc/self/statm``) is read after a warm-up and then every ``--every`` trials; the growth over the measured trials
and the slope per trial (least squares over the samples) are printed. Target: < 50 MB over 500 trials.

    python benchmarks/memory.py --trials 500                      # pick_place.toml, 1 sim second each
    python benchmarks/memory.py --trials 100 --config configs/sort_robot.toml --max-time 2
"""

from __future__ import annotations

import argparse
import gc
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def rss_mb() -> float:
    """Resident set size of this process now, MB."""
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def one_trial(config: Path, seed: int, max_time: float) -> str:
    """Everything ``robokit run`` does after start-up, for one seed; returns the outcome."""
    from robokit.config import load_config
    from robokit.plugin_api.plugins import load_plugins
    from robokit.runner import run_config

    plugins = load_plugins()
    cfg = load_config(config, plugins, {"world.seed": seed})
    out = run_config(cfg, plugins, max_time=max_time)
    return out.result.outcome


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=500)
    parser.add_argument("--warmup", type=int, default=10, help="trials before the first measurement")
    parser.add_argument("--every", type=int, default=25, help="trials between RSS samples")
    parser.add_argument("--config", type=Path, default=ROOT / "configs" / "pick_place.toml")
    parser.add_argument("--max-time", type=float, default=1.0, help="sim seconds per trial")
    args = parser.parse_args()
    config = args.config.resolve()
    print(f"load: {' '.join(f'{v:.2f}' for v in os.getloadavg())}; {config.name}, {args.max_time:g} sim s a trial, "
          f"{args.warmup} warm-up + {args.trials} measured trials", flush=True)
    outcomes: dict[str, int] = {}
    samples: list[tuple[int, float]] = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # the local reporter writes results/ here
        for i in range(args.warmup + args.trials):
            outcome = one_trial(config, i, args.max_time)
            outcomes[outcome] = outcomes.get(outcome, 0) + 1
            k = i + 1 - args.warmup
            if k >= 0 and (k % args.every == 0 or k == args.trials):
                gc.collect()
                samples.append((k, rss_mb()))
                print(f"  after {k:4d} measured trials: RSS {samples[-1][1]:7.1f} MB", flush=True)
    xs, ys = [s[0] for s in samples], [s[1] for s in samples]
    slope = statistics.linear_regression(xs, ys).slope if len(samples) > 1 else 0.0
    growth = ys[-1] - ys[0]
    print(f"RSS growth over {args.trials} trials: {growth:+.1f} MB ({slope * 1000:+.1f} kB a trial, fitted); "
          f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3:.0f} MB; "
          f"outcomes {outcomes}; {time.perf_counter() - t0:.0f} s   (target < 50 MB over 500)")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
