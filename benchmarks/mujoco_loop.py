"""robokit's MuJoCo loop against bare MuJoCo stepping the same motion: what robokit itself costs per tick.

    python benchmarks/mujoco_loop.py            # needs valgrind: instructions per sim second, three ways

``benchmarks/engines.py --loop`` compares robokit's loop with the compiled model stepped bare from the state after
set-up, where nothing moves: the arm stands, nothing is grasped, so MuJoCo's own work differs too. Here the bare
loop replays the motion robokit ran. The main job (``configs/sort_robot.toml``, seed 3) runs ticks 1 to 421 (the
sort approaches, grasps and carries its first cube) once uncounted, recording what robokit handed MuJoCo before
each step (controls, applied forces, the motors' gains and armatures, the equality constraints and whether each is
on); then, counted, (a) robokit runs those ticks again from a copy of the same start, and (b) a plain loop sets
the recorded inputs and calls ``mj_step2`` / ``mj_step1`` on another copy, as robokit's World does (and
``mj_forward`` where a grip anchor let go). The bare replay's final state is compared with robokit's (it prints
the largest difference of ``qpos``: 0 when the replay is the same motion).

Only the loop is counted (valgrind's callgrind, ``--toggle-collect`` on CPython's ``functools_reduce``, which
nothing in either loop enters); the figure machine load does not change.
"""

from __future__ import annotations

import argparse
import copy
import functools
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
TICKS = 420
MODEL_FIELDS = ("actuator_gainprm", "actuator_biasprm", "actuator_forcerange", "actuator_forcelimited",
                "dof_armature", "eq_obj2id", "eq_data")
"""What robokit changes in a compiled model while it runs (motors' gains, armatures, the grip anchors' welds)."""


def build() -> Any:
    """The main job on MuJoCo (seed 3), after set-up and its first tick."""
    from robokit.config import load_config
    from robokit.core.simulation import Simulation
    from robokit.plugin_api.plugins import load_plugins

    plugins = load_plugins()
    cfg = load_config(ROOT / "configs" / "sort_robot.toml", plugins, {"world.engine": "mujoco", "world.seed": 3})
    sim = Simulation(cfg, plugins)
    sim.step(1)
    return sim


def record(sim: Any, ticks: int) -> list[dict[str, Any]]:
    """Run ``ticks`` ticks of ``sim``; per tick, the inputs robokit handed MuJoCo as its step began."""
    import robokit.engines.mujoco.world as world_module
    from robokit.engines.mujoco.gl import mujoco

    m, d = sim.world.client.model, sim.world.client.data
    inputs: list[dict[str, Any]] = []

    def snapshot() -> None:
        inputs.append({"ctrl": d.ctrl.copy(), "qfrc_applied": d.qfrc_applied.copy(),
                       "eq_active": d.eq_active.copy(), **{f: getattr(m, f).copy() for f in MODEL_FIELDS}})

    class Recording:
        def __getattr__(self, name: str) -> Any:
            return getattr(mujoco, name)

        @staticmethod
        def mj_step2(model: Any, data: Any) -> None:
            snapshot()
            mujoco.mj_step2(model, data)

        @staticmethod
        def mj_fwdActuation(model: Any, data: Any) -> None:  # the step of a world holding something by a weld
            snapshot()
            mujoco.mj_fwdActuation(model, data)

        @staticmethod
        def mj_forward(model: Any, data: Any) -> None:  # a weld let go: the step solved again without it
            inputs[-1]["let_go"] = data.eq_active.copy()
            mujoco.mj_forward(model, data)

    world_module.mujoco = Recording()  # type: ignore[assignment]
    try:
        sim.step(ticks)
    finally:
        world_module.mujoco = mujoco
    return inputs


def plan(inputs: list[dict[str, Any]]) -> list[tuple[Any, ...]]:
    """The recorded inputs as the replay writes them (worked out before counting): per step, the model fields that
    changed since the step before, the controls, applied forces, equality switches, and those of a let-go."""
    steps: list[tuple[Any, ...]] = []
    last: dict[str, Any] = {}
    for step in inputs:
        writes = [(name, step[name]) for name in MODEL_FIELDS
                  if name not in last or not (last[name] == step[name]).all()]
        last.update(writes)
        steps.append((writes, step["ctrl"], step["qfrc_applied"], step["eq_active"], step.get("let_go")))
    return steps


def replay(model: Any, data: Any, steps: list[tuple[Any, ...]]) -> None:
    """Step ``model`` / ``data`` bare through the planned inputs, as robokit's World steps."""
    from robokit.engines.mujoco.gl import mujoco

    for writes, ctrl, applied, active, let_go in steps:
        if writes:  # new gains or armatures: the mass matrix again, as robokit's World does
            for name, value in writes:
                getattr(model, name)[:] = value
            mujoco.mj_step1(model, data)
        data.ctrl[:] = ctrl
        data.qfrc_applied[:] = applied
        data.eq_active[:] = active
        if let_go is not None:  # solved again without the weld let go, as robokit's World does
            data.eq_active[:] = let_go
            mujoco.mj_forward(model, data)
        mujoco.mj_step2(model, data)
        mujoco.mj_step1(model, data)


def counted(run: Any) -> None:
    """Call ``run`` from inside ``functools.reduce``: the C function callgrind counts within."""
    functools.reduce(lambda _a, _b: run(), (None, None))


def loop_only(how: str, ticks: int) -> None:
    """``--loop-only``: the counted loop ``how`` (``robokit`` or ``bare``); then the comparison of its final state
    with a recorded run's (the recording is made before a bare loop, after robokit's, so that robokit's loop runs
    with nothing more in memory than in ``benchmarks/engines.py --loop``)."""
    import numpy as np

    sim = build()
    if how == "robokit":
        counted(lambda: sim.step(ticks))
        final = sim.world.client.data.qpos.copy()
        first = build()
        record(first, ticks)
    else:
        start_model, start_data = copy.copy(sim.world.client.model), copy.copy(sim.world.client.data)
        first = build()
        steps = plan(record(first, ticks))
        counted(lambda: replay(start_model, start_data, steps))
        final = start_data.qpos.copy()
    expected = first.world.client.data.qpos
    print(f"largest qpos difference from the recorded run: {float(np.abs(final - expected).max()):.3g}")
    first.close()
    sim.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--loop-only", choices=("robokit", "bare"), help=argparse.SUPPRESS)
    parser.add_argument("--ticks", type=int, default=TICKS)
    args = parser.parse_args(argv)
    if args.loop_only:
        loop_only(args.loop_only, args.ticks)
        return 0
    seconds = args.ticks / 240.0
    per_second = {}
    print(f"{'loop':28} {'instructions per sim s':>24} {'x bare replay':>14}")
    for how in ("bare", "robokit"):
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "callgrind.out"
            run = subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no",
                                  "--toggle-collect=functools_reduce", f"--callgrind-out-file={out}", sys.executable,
                                  __file__, "--loop-only", how, "--ticks", str(args.ticks)],
                                 check=True, capture_output=True, text=True)
            total = next(line for line in out.read_text().splitlines() if line.startswith(("summary:", "totals:")))
        per_second[how] = int(total.split()[1]) / seconds
        note = run.stdout.strip().splitlines()[-1]
        print(f"{how + ' (same motion)' if how == 'bare' else how:28} {per_second[how]:>24,.0f} "
              f"{per_second[how] / per_second['bare']:>14.2f}   {note}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
