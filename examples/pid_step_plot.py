"""Plot a PID step response from a config with a ``pid`` actuator (``configs/pid_kuka.toml``) as a PNG.

    python examples/pid_step_plot.py configs/pid_kuka.toml -o pid_step.png [--joint lbr_iiwa_joint_2]

Runs the config headless tick by tick (no behaviour needed), reads the controller's state every tick and draws the
setpoint and the joint position (top) and the torque with its P, I and D terms (bottom). Prints the step's
overshoot, rise time, 2 % settling time and steady-state error. Needs matplotlib (``pip install 'robokit[video]'``).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def simulate(config: str, joint: str | None, seconds: float | None) -> dict[str, np.ndarray | str]:
    """Step the config and collect the ``pid`` actuator's state of one joint every tick."""
    from robokit_plugins.pid import Pid

    from robokit.testing import make_sim

    with make_sim(config) as sim:
        names = [n for n, c in sim.components.items() if isinstance(c, Pid)]
        if not names:
            raise SystemExit(f"pid_step_plot: error: {config} has no pid actuator")
        pid = names[0]
        joint = joint or sim.components[pid].names[0]
        ticks = round((seconds or sim.config.world.max_time) / sim.world.time_step)
        rows = []
        for _ in range(ticks):
            sim.step(1)
            s = sim.readings[pid]
            rows.append((sim.world.time, s.setpoints[joint], s.positions[joint], s.torques[joint],
                         s.p_terms[joint], s.i_terms[joint], s.d_terms[joint]))
    data = np.array(rows)
    keys = ("t", "setpoint", "position", "torque", "p", "i", "d")
    return {"joint": joint, **{k: data[:, i] for i, k in enumerate(keys)}}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Plot a PID step response as a PNG")
    parser.add_argument("config")
    parser.add_argument("-o", "--out", default="pid_step.png")
    parser.add_argument("--joint")
    parser.add_argument("--seconds", type=float)
    args = parser.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from robokit_plugins.pid import step_metrics

    d = simulate(args.config, args.joint, args.seconds)
    t, sp, q = d["t"], d["setpoint"], d["position"]
    assert isinstance(t, np.ndarray) and isinstance(sp, np.ndarray) and isinstance(q, np.ndarray)
    changes = np.flatnonzero(np.diff(sp))
    if len(changes):
        k = changes[0] + 1
        m = step_metrics(t, q, float(sp[k - 1]), float(sp[k]), t_step=float(t[k]))
        print(f"step {sp[k - 1]:g} -> {sp[k]:g} rad at t = {t[k]:.3f} s: overshoot {m.overshoot:.1%}, "
              f"rise {m.rise_time:.3f} s, 2 % settling {m.settling_time:.3f} s, steady error {m.steady_error:.2e} rad")
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    ax1.plot(t, sp, "k--", label="setpoint")
    ax1.plot(t, q, label="position")
    ax1.set_ylabel("rad")
    ax1.set_title(f"PID step response: {d['joint']}")
    ax1.legend()
    for key in ("torque", "p", "i", "d"):
        ax2.plot(t, d[key], label=key if key == "torque" else f"{key.upper()} term")
    ax2.set_xlabel("sim time (s)")
    ax2.set_ylabel("N·m")
    ax2.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
