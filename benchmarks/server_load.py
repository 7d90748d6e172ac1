"""Load on the course server's SQLite default: N concurrent posters, every result stored exactly once.

Starts ``robokit serve`` (waitress, SQLite in WAL mode with a busy timeout, IMMEDIATE transactions) on 127.0.0.1 in
a temporary data folder, makes a class with one student (and token) per client, then runs N client threads, each
posting M full robokit payloads with robokit's own HTTP client (urllib3 ``Retry``: connection errors, 5xx, 429 are
retried with backoff) and resending every 10th one (as an outbox flush after a lost answer would). Afterwards it
reads the database: every run id present exactly once, no extra rows.

Figures: requests answered, retries, latency p50 / p95 / p99 per POST, throughput; and the same figures for one
client alone first (the baseline, same server, same process), with the concurrent/alone p95 ratio.

    python benchmarks/server_load.py --clients 20 --posts 50
"""

from __future__ import annotations

import argparse
import json
import os
import sqlite3
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from server_proc import Server, free_port, robokit  # noqa: E402

from robokit.core.result import RunResult  # noqa: E402
from robokit.report.reporting import build_payload  # noqa: E402


def payload(client: int, i: int, student: str) -> dict[str, Any]:
    r = RunResult(run_id=f"load-{client:03d}-{i:05d}-{os.getpid()}", robokit_version="0.1.0",
                  config="configs/sort_robot.toml", behaviour="sort", seed=i, outcome="succeeded", reason="sorted",
                  ticks=1910, sim_time=7.96, wall_time=1.2, started_at="2026-11-23T10:00:00+00:00",
                  result={"red_sorted": 2, "blue_sorted": 2, "failures": i % 3, "total_time": 7.5 + (i % 7) * 0.1,
                          "objects": [{"colour": "red", "detected_position": [0.4, 0.1, 0.025]}] * 4})
    return build_payload(r, student=student, project="A")


def poster(url: str, client: int, posts: int, token: str, out: dict[str, Any], start: threading.Barrier) -> None:
    """One client: robokit's retrying session, M posts (every 10th sent twice), latency of each POST."""
    from robokit_plugins.http_report import HttpOptions, encode, make_session, post

    opts = HttpOptions(retries=8, backoff_factor=0.1, backoff_max=2.0, backoff_jitter=0.1, read_timeout=60.0)
    session = make_session(opts)
    latencies, statuses, failures = [], [], []
    start.wait()
    for i in range(posts):
        p = payload(client, i, f"client{client}")
        for _ in range(2 if i % 10 == 9 else 1):
            t0 = time.perf_counter()
            res = post(session, url, encode(p), p["run_id"], opts, token)
            latencies.append(time.perf_counter() - t0)
            statuses.append(res.status)
            if not res.ok:
                failures.append(res.detail)
    session.close()
    out[client] = {"latencies": latencies, "statuses": statuses, "failures": failures}


def run(url: str, clients: int, posts: int, tokens: list[str], offset: int) -> dict[str, Any]:
    out: dict[int, Any] = {}
    barrier = threading.Barrier(clients)
    threads = [threading.Thread(target=poster, args=(url, offset + c, posts, tokens[c], out, barrier))
               for c in range(clients)]
    t0 = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.perf_counter() - t0
    lat = sorted(x for v in out.values() for x in v["latencies"])
    statuses = [s for v in out.values() for s in v["statuses"]]
    q = statistics.quantiles(lat, n=100, method="inclusive") if len(lat) > 1 else lat * 99
    return {"requests": len(lat), "wall": wall, "p50": q[49], "p95": q[94], "p99": q[98], "max": lat[-1],
            "statuses": {s: statuses.count(s) for s in sorted(set(statuses), key=str)},
            "failures": [f for v in out.values() for f in v["failures"]]}


def show(label: str, r: dict[str, Any]) -> None:
    print(f"{label}: {r['requests']} POSTs in {r['wall']:.1f} s ({r['requests'] / r['wall']:.0f}/s); latency "
          f"p50 {r['p50'] * 1000:.0f} ms, p95 {r['p95'] * 1000:.0f} ms, p99 {r['p99'] * 1000:.0f} ms, "
          f"max {r['max'] * 1000:.0f} ms; answers {r['statuses']}; failed {len(r['failures'])}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--clients", type=int, default=20)
    parser.add_argument("--posts", type=int, default=50, help="posts per client")
    parser.add_argument("--threads", type=int, default=8, help="server worker threads")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="robokit-load-") as tmp:
        data, port = Path(tmp) / "srv", free_port()
        env = {"ROBOKIT_TEACHER_PASSWORD": "load-test-password"}
        robokit("serve", "--data", str(data), "--create-teacher", "teacher", cwd=Path(tmp), env=env)
        robokit("manage", "--data", str(data), "create_class", "load", "--teacher", "teacher", cwd=Path(tmp))
        names = [f"client{c}" for c in range(args.clients + 1)]
        out = robokit("manage", "--data", str(data), "add_students", "load", *names, cwd=Path(tmp)).stdout
        tokens = [line.split("\t")[1] for line in out.strip().splitlines()]
        server = Server(data, port, extra=("--threads", str(args.threads))).start()
        try:
            url = f"{server.url}/api/robotics/result/"
            alone = run(url, 1, args.posts, tokens[-1:], offset=args.clients)
            show("1 client alone (baseline)", alone)
            loaded = run(url, args.clients, args.posts, tokens, offset=0)
            show(f"{args.clients} clients at once", loaded)
        finally:
            server.stop()
        db = sqlite3.connect(data / "db.sqlite3")
        rows = db.execute("SELECT run_id FROM course_result").fetchall()
        mode = db.execute("PRAGMA journal_mode").fetchone()[0]
        db.close()
    expected = {payload(c, i, "")["run_id"] for c in range(args.clients + 1) for i in range(args.posts)}
    ids = [r[0] for r in rows]
    once = len(ids) == len(set(ids)) == len(expected) and set(ids) == expected
    print(f"stored: {len(ids)} rows for {len(expected)} distinct runs (each posted once, every 10th twice): "
          f"{'every result exactly once' if once else 'MISMATCH'}; journal_mode={mode}")
    print(f"p95 under load / alone: {loaded['p95'] / alone['p95']:.1f}x")
    print(f"machine load (uptime): {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f} "
          f"on {os.cpu_count()} cores")
    print(json.dumps({"alone": {k: v for k, v in alone.items() if k != "failures"},
                      "loaded": {k: v for k, v in loaded.items() if k != "failures"}}, default=str))
    return 0 if once and not loaded["failures"] and not alone["failures"] else 1


if __name__ == "__main__":
    sys.exit(main())
