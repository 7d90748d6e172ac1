"""The recorder: a monitor that keeps a run's record in ``<dir>/<run_id>/`` while the run goes.

It sits in the loop as a monitor slot (:meth:`robokit.core.simulation.Simulation.add_monitor`): the scheduler calls
:meth:`Recorder.sample` at the start of every ``period``-th tick, before anything else happens in that tick, so a
sample at tick ``k`` is the scene at sim time ``k * time_step``. Trace records (state transitions, events,
``record``-ed readings) stream into ``trace.jsonl`` as they happen; the pose log is kept in memory (a few hundred
kilobytes for a minute of the main job) and written to ``poses.npz`` at the end. The format is in ``docs/records.md``.

At the end of a run the runner calls :meth:`Recorder.finish` (last sample, the trace's ``end`` record: quick), then
delivers the result, then :meth:`Recorder.write_poses` (the slow part): ``result.json`` exists before the pose log.
A write that fails (a full disk, a file-size limit) never raises: it stops that file and is reported as one line
naming the file and the reason (:attr:`Recorder.failure`, the list :meth:`write_poses` returns).
"""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path
from typing import IO, Any

import numpy as np
import pybullet as p

from robokit import __version__
from robokit.core.result import jsonable
from robokit.record.atomic import part_name
from robokit.record.layout import POSES_FILE, RECORD_SCHEMA, TRACE_FILE, machines_of


class Recorder:
    """Writes ``trace.jsonl`` (a header, then events) and ``poses.npz`` (bodies' base poses and joint positions).

    Args:
        sim: The simulation to record (its bodies, joints, behaviour and trace).
        folder: The run's folder, ``<results dir>/<run_id>``; created if missing.
        pose_hz: Pose samples per sim second (0 = no pose log). Rounded to a whole number of physics ticks.
    """

    kind = "monitor"

    def __init__(self, sim: Any, folder: str | Path, *, pose_hz: float = 30.0) -> None:
        self.sim = sim
        self.world = sim.world
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        hz = self.world.physics_hz
        self.pose_hz = float(pose_hz)
        self.period = max(1, round(hz / pose_hz)) if pose_hz > 0 else 0
        self._layout = self._body_layout()
        self._ticks: list[int] = []
        self._rows: list[list[float]] = []
        self._removals = self.world.removals
        self._present = [True] * len(self._layout)
        self.failure: str | None = None
        """One line naming the trace file and why writing it stopped (None while it is written in full)."""
        self._trace: IO[str] | None = open(self.folder / TRACE_FILE, "w", encoding="utf-8")  # noqa: SIM115
        self._write(self.header())
        sim.trace_listeners.append(self._on_trace)

    # ----------------------------------------------------------------- header
    def _body_layout(self) -> list[tuple[str, int, list[int]]]:
        w = self.world
        return [(name, w.body(name), [j.index for j in w.joints(name) if j.movable]) for name in w.body_names]

    def header(self) -> dict[str, Any]:
        """The first line of ``trace.jsonl``: versions, config, seed, bodies and the state machines' structure."""
        cfg, w = self.sim.config, self.world
        source = Path(cfg.source)
        text = source.read_text(encoding="utf-8") if source.is_file() else None
        bodies = {}
        for name, _bid, movable in self._layout:
            joints = w.joints(name)
            bodies[name] = {
                "links": w.link_names(name),
                "joints": [joints[i].name for i in movable],
            }
        return jsonable({
            "kind": "header",
            "schema": RECORD_SCHEMA,
            "robokit_version": __version__,
            "run_id": self.sim.run_id,
            "created_at": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
            "config_path": str(source.resolve()) if text is not None else cfg.source,
            "config_dir": str(Path(cfg.base_dir).resolve()),
            "config_text": text,
            "config": dict(cfg.raw),
            "seed": self.sim.seed,
            "time_step": w.time_step,
            "pose_hz": (w.physics_hz / self.period) if self.period else 0,
            "bodies": bodies,
            "machines": machines_of(self.sim.behaviour),
        })

    # ----------------------------------------------------------------- trace
    def _write(self, record: dict[str, Any]) -> None:
        if self._trace is None or self.failure is not None:
            return
        try:
            self._trace.write(json.dumps(jsonable(record)) + "\n")
        except OSError as exc:
            self.failure = (f"run record: writing {self.folder / TRACE_FILE} failed at tick {record.get('tick', 0)}: "
                            f"{exc.strerror or exc}; the trace stops there")

    def _on_trace(self, record: dict[str, Any]) -> None:
        self._write(record)

    # ----------------------------------------------------------------- poses
    def sample(self, tick: int) -> None:
        """Log every body's base pose and joint positions now (the scheduler calls this at the tick's start)."""
        if self.world.removals != self._removals:
            self._removals = self.world.removals
            self._present = [self.world.has_body(name) for name, _, _ in self._layout]
        if self.world.engine != "pybullet":  # the World's own calls (the raw pybullet ones below are the fast path)
            self._sample_world(tick)
            return
        cid = self.world.cid
        base, joints = p.getBasePositionAndOrientation, p.getJointStates
        row: list[float] = []
        nan7 = [np.nan] * 7
        for (_, bid, movable), present in zip(self._layout, self._present, strict=True):
            if not present:
                row += nan7
                row += [np.nan] * len(movable)
                continue
            pos, orn = base(bid, physicsClientId=cid)
            row += pos
            row += orn
            if movable:
                row += [s[0] for s in joints(bid, movable, physicsClientId=cid)]
        self._ticks.append(tick)
        self._rows.append(row)

    def _sample_world(self, tick: int) -> None:
        """:meth:`sample` through the World interface (engines other than PyBullet): base poses in the centre-of-mass
        frame, as the PyBullet path logs them and the replays set them."""
        row: list[float] = []
        for (_, bid, movable), present in zip(self._layout, self._present, strict=True):
            if not present:
                row += [np.nan] * (7 + len(movable))
                continue
            pos, orn = self.world.com_pose(bid)
            row += [*pos, *orn]
            if movable:
                row += [s[0] for s in self.world.joint_states(bid, movable)]
        self._ticks.append(tick)
        self._rows.append(row)

    def poses(self) -> dict[str, np.ndarray]:
        """The pose log as the arrays ``poses.npz`` holds (see ``docs/records.md``)."""
        data = np.asarray(self._rows, dtype=np.float64).reshape(len(self._rows), -1)
        out: dict[str, np.ndarray] = {
            "tick": np.asarray(self._ticks, dtype=np.int64),
            "t": np.asarray(self._ticks, dtype=np.float64) * self.world.time_step,
        }
        col = 0
        for name, _bid, movable in self._layout:
            out[f"base/{name}"] = data[:, col:col + 7].astype(np.float32)
            col += 7
            if movable:
                out[f"joints/{name}"] = data[:, col:col + len(movable)].astype(np.float32)
                col += len(movable)
        return out

    # ----------------------------------------------------------------- end
    def finish(self, result: Any = None) -> None:
        """Take a last sample of the final state, write the ``end`` record and close the trace; safe to call twice."""
        if self._trace is None:
            return
        if self.period and self.world.client is not None and (not self._ticks or self._ticks[-1] != self.world.tick):
            self.sample(self.world.tick)
        if result is not None:
            self._write({"kind": "end", "tick": result.ticks, "t": result.sim_time, "outcome": result.outcome,
                         "reason": result.reason})
        self._close_trace()

    def _close_trace(self) -> None:
        trace, self._trace = self._trace, None
        if trace is not None:
            try:
                trace.close()  # flushes what is buffered: a full disk may show here
            except OSError as exc:
                if self.failure is None:
                    self.failure = (f"run record: writing {self.folder / TRACE_FILE} failed at its end: "
                                    f"{exc.strerror or exc}")
        if self._on_trace in self.sim.trace_listeners:
            self.sim.trace_listeners.remove(self._on_trace)

    def write_poses(self) -> list[str]:
        """Write ``poses.npz`` (through a temporary file and a rename); the failures, one line each ([] if none).

        A write that is broken into (``Interrupted``) leaves no temporary file behind and passes the interrupt on.
        """
        self.finish()
        if not self.period or not self._ticks:
            return []
        tmp, path = part_name(self.folder / POSES_FILE), self.folder / POSES_FILE
        try:
            np.savez_compressed(tmp, **self.poses())  # type: ignore[arg-type]
            with np.load(tmp) as back:  # checked before it takes the name: every sample is there
                whole = len(back["t"]) == len(self._ticks)
            if not whole:
                return [f"run record: {path} read back short; the pose log was not kept"]
            tmp.replace(path)
        except (OSError, ValueError, KeyError) as exc:
            why = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
            return [f"run record: writing {path} failed: {why}; the pose log was not kept"]
        finally:
            tmp.unlink(missing_ok=True)
        return []

    def abandon(self) -> None:
        """Stop recording: close the trace where it is, write no pose log, leave no temporary file."""
        self.period = 0
        self._close_trace()
        part_name(self.folder / POSES_FILE).unlink(missing_ok=True)

    def close(self, result: Any = None) -> list[str]:
        """:meth:`finish`, then :meth:`write_poses` (for code that records a simulation it runs itself)."""
        self.finish(result)
        return self.write_poses()
