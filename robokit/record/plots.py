"""``robokit plot``: pictures of a run, chosen by what its record holds (matplotlib, headless Agg backend).

- ``states.<fmt>``: a state timeline (Gantt) per state machine — every run with a machine;
- ``map.<fmt>``: top-down map for mobile runs (a ``diff_drive`` actuator): static bodies, driven path, waypoints
  and goal, objects found by the lidar against the truth;
- ``heights.<fmt>``: body heights over time — the drop test (or any run with free bodies and no robot);
- ``joints.<fmt>``: joint angles over time for each body a ``joint_control`` actuator drives;
- ``lidar.<fmt>``: a polar plot of the lidar scan at a chosen sim time (re-cast on the recorded poses).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from robokit.record.fonts import korean_font, quiet_missing_glyphs
from robokit.record.format import RunRecord


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


_STYLE = {"figure.dpi": 100, "savefig.bbox": "tight", "font.size": 9}
"""Matplotlib settings for robokit's pictures, applied only while they are drawn (the caller's are left alone)."""


def _sections(rec: RunRecord, section: str) -> dict[str, dict[str, Any]]:
    table = rec.header["config"].get(section, {})
    return {k: v for k, v in table.items() if isinstance(v, dict)}


def _of_type(rec: RunRecord, section: str, type_name: str) -> dict[str, dict[str, Any]]:
    return {k: v for k, v in _sections(rec, section).items() if v.get("type") == type_name}


def make_plots(rec: RunRecord, out: Path, *, fmt: str = "png", scan_at: float | None = None) -> list[Path]:
    """Write every picture that fits the record into ``out``; returns their paths."""
    out.mkdir(parents=True, exist_ok=True)
    plt = _pyplot()
    written: list[Path] = []
    makers = [plot_states, plot_map, plot_heights, plot_joints]
    family = korean_font(warn=False)  # names in a config may be Korean: drawn when a Korean font is there
    style = {**_STYLE, "font.sans-serif": [family, *plt.rcParams["font.sans-serif"]]} if family else _STYLE
    with plt.rc_context(style), quiet_missing_glyphs(warn=False):
        for maker in makers:
            fig = maker(rec, plt)
            if fig is not None:
                written.append(_save(fig, out / f"{maker.__name__[5:]}.{fmt}", plt))
        if _of_type(rec, "sensors", "lidar") and rec.has_poses:
            fig = plot_lidar(rec, plt, scan_at)
            if fig is not None:
                written.append(_save(fig, out / f"lidar.{fmt}", plt))
    return written


def _save(fig: Any, path: Path, plt: Any) -> Path:
    """Save under a temporary name and rename (:mod:`robokit.record.atomic`): a picture is whole or absent."""
    from robokit.record.atomic import atomic_output

    try:
        with atomic_output(path) as tmp:
            fig.savefig(tmp, format=path.suffix.lstrip(".") or "png")
    finally:
        plt.close(fig)
    return path


def _title(rec: RunRecord) -> str:
    r = rec.result
    config = Path(str(r.get("config") or rec.header.get("config_path", ""))).name
    return f"{config}  seed {rec.header.get('seed')}  {r.get('outcome', '')}  ({rec.run_id[:8]})"


# ----------------------------------------------------------------- states
def plot_states(rec: RunRecord, plt: Any) -> Any:
    """One row per machine, one coloured bar per stay in a state, labelled with the state's name where the name
    fits inside its bar; a stay too short to see as a bar (a 0-second state: DONE, a LOOK decided at once) is a
    marker on top of its row."""
    spans = {name: s for name, s in rec.spans().items() if s}
    if not spans:
        return None
    states = sorted({s.state for stays in spans.values() for s in stays})
    cmap = plt.get_cmap("tab20")
    colour = {s: cmap(i % 20) for i, s in enumerate(states)}
    fig, ax = plt.subplots(figsize=(10, 0.8 + 0.9 * len(spans)))
    end = max(rec.sim_time, 1e-3)
    ax.set_xlim(0, end)
    ax.set_ylim(len(spans) - 0.5, -0.5)  # the first machine on top
    shortest = end / 400  # about two pixels at this figure's width
    labels = []
    for row, stays in enumerate(spans.values()):
        for s in stays:
            width = s.end - s.start
            if width < shortest:
                ax.plot([s.start], [row - 0.4], marker="v", ms=6, color=colour[s.state], markeredgecolor="black",
                        markeredgewidth=0.5, linestyle="none", zorder=3, clip_on=False)
                continue
            ax.barh(row, width, left=s.start, color=colour[s.state], edgecolor="white", linewidth=0.5)
            labels.append((ax.text(s.start + width / 2, row, s.state, ha="center", va="center", fontsize=7),
                           s.start, s.end))
    _keep_fitting(fig, ax, labels)
    ax.set_yticks(range(len(spans)), list(spans))
    ax.set_xlabel("sim time (s)")
    handles = [plt.Rectangle((0, 0), 1, 1, color=colour[s]) for s in states]
    ax.legend(handles, states, ncol=min(6, len(states)), fontsize=7, loc="upper center",
              bbox_to_anchor=(0.5, -0.35 if len(spans) < 3 else -0.15), frameon=False)
    ax.set_title("state timeline  " + _title(rec) + "\n(\u25bc a state left in the tick it was entered)")
    return fig


def _keep_fitting(fig: Any, ax: Any, labels: list[tuple[Any, float, float]]) -> None:
    """Remove each bar label wider than its bar (it would be cut off or spill over its neighbours)."""
    renderer = fig.canvas.get_renderer()
    for text, start, stop in labels:
        left, right = ax.transData.transform([(start, 0), (stop, 0)])[:, 0]
        if text.get_window_extent(renderer).width > (right - left) - 2:
            text.remove()


# ----------------------------------------------------------------- map
def _robot_of(rec: RunRecord) -> str | None:
    for section in ("actuators", "sensors"):
        for spec in _sections(rec, section).values():
            if spec.get("type") in ("diff_drive", "lidar"):
                return str(spec.get("robot", "robot"))  # the types' default robot name
    return None


def _box_outline(size: Any, pose: np.ndarray) -> np.ndarray:
    """The xy corners of a box of ``size`` at a base pose (x, y, z, qx, qy, qz, qw), closed."""
    hx, hy = size[0] / 2, size[1] / 2
    qx, qy, qz, qw = pose[3:7]
    yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    c, s = math.cos(yaw), math.sin(yaw)
    corners = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy], [-hx, -hy]])
    return corners @ np.array([[c, s], [-s, c]]) + pose[:2]


def plot_map(rec: RunRecord, plt: Any) -> Any:
    """Top-down: boxes (static dark, free light), the driven path, waypoints / goal, found objects vs truth."""
    robot = _robot_of(rec)
    if robot is None or not rec.has_poses or f"base/{robot}" not in rec.poses:
        return None
    poses = rec.poses
    bodies = {**_sections(rec, "bodies"), **_sections(rec, "robots")}
    fig, ax = plt.subplots(figsize=(7, 7))
    for name in rec.header["bodies"]:
        spec = bodies.get(name) or bodies.get(name.rsplit("_", 1)[0]) or {}
        track = poses.get(f"base/{name}")
        if track is None or name == robot or spec.get("shape") != "box" or np.isnan(track[0, 0]):
            continue
        size = spec.get("size", (0.1, 0.1, 0.1))
        if size[0] > 20 or size[1] > 20:
            continue
        static = float(spec.get("mass", 1.0)) == 0
        outline = _box_outline(size, track[0])
        ax.fill(outline[:, 0], outline[:, 1], color="0.35" if static else "0.75", zorder=1)
    for name in rec.header["bodies"]:
        spec = bodies.get(name) or bodies.get(name.rsplit("_", 1)[0]) or {}
        track = poses.get(f"base/{name}")
        if track is not None and spec.get("shape") in ("cylinder", "sphere") and not np.isnan(track[0, 0]):
            ax.plot(track[0, 0], track[0, 1], "o", color="tab:orange", ms=7, zorder=3,
                    label="object (start, truth)" if "object (start, truth)" not in _labels(ax) else None)
    path = poses[f"base/{robot}"]
    ok = ~np.isnan(path[:, 0])
    ax.plot(path[ok, 0], path[ok, 1], "-", color="tab:blue", lw=1.5, label="driven path", zorder=4)
    ax.plot(path[ok, 0][:1], path[ok, 1][:1], "s", color="tab:blue", ms=8, label="start", zorder=5)
    behaviour = rec.header["config"].get("behaviour", {})
    waypoints = behaviour.get("waypoints") or ([behaviour["goal"]] if "goal" in behaviour else [])
    for i, (x, y) in enumerate(waypoints):
        ax.plot(x, y, "*", color="tab:green", ms=14, zorder=6, label="waypoint / goal" if i == 0 else None)
        ax.annotate(str(i), (x, y), textcoords="offset points", xytext=(6, 6), color="tab:green")
    for i, found in enumerate((rec.result.get("result") or {}).get("found", [])):
        est = found.get("estimate")
        if est:
            ax.plot(est[0], est[1], "x", color="tab:red", ms=9, mew=2, zorder=7,
                    label="found by lidar (estimate)" if i == 0 else None)
        if est and found.get("true"):
            ax.plot([est[0], found["true"][0]], [est[1], found["true"][1]], "-", color="tab:red", lw=0.8)
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="best", fontsize=8)
    ax.set_title("top-down map  " + _title(rec))
    return fig


def _labels(ax: Any) -> list[str]:
    return [h.get_label() for h in ax.get_lines()]


# ----------------------------------------------------------------- heights and joints
def plot_heights(rec: RunRecord, plt: Any) -> Any:
    """Base height of every free body over time (the drop test's bounces). Each body named in the config has its
    own colour and legend entry; the copies of a ``count = N`` body share one colour and one entry."""
    behaviour = rec.header["config"].get("behaviour", {}).get("type")
    if not rec.has_poses or (behaviour != "drop_test" and (_robot_of(rec) or _sections(rec, "robots"))):
        return None
    poses, bodies = rec.poses, {**_sections(rec, "bodies")}
    free = [n for n in rec.header["bodies"]
            if float((bodies.get(n) or bodies.get(n.rsplit("_", 1)[0]) or {}).get("mass", 1.0)) > 0
            and f"base/{n}" in poses and not (bodies.get(n) or {}).get("urdf") == "plane.urdf"]
    if not free:
        return None
    groups: dict[str, list[str]] = {}
    for name in free:
        groups.setdefault(name if name in bodies else name.rsplit("_", 1)[0], []).append(name)
    fig, ax = plt.subplots(figsize=(11, 5))
    cmap = plt.get_cmap("tab20" if len(groups) > 10 else "tab10")
    for i, (section, names) in enumerate(groups.items()):
        many = len(names) > 1
        for k, name in enumerate(names):
            label = (f"{section}_0 .. {section}_{len(names) - 1} ({len(names)})" if many else name) if k == 0 else None
            ax.plot(poses["t"], poses[f"base/{name}"][:, 2], lw=0.7 if many else 1.2, alpha=0.6 if many else 1.0,
                    color="0.5" if many else cmap(i % cmap.N), label=label, zorder=1 if many else 2)
    ax.set_xlabel("sim time (s)")
    ax.set_ylabel("height z (m)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False,
              ncol=1 + len(groups) // 25)
    ax.set_title(f"body heights ({len(free)} bodies)  " + _title(rec))
    return fig


def plot_joints(rec: RunRecord, plt: Any) -> Any:
    """Joint positions over time for every body a ``joint_control`` actuator drives."""
    driven = [spec.get("body") for spec in _of_type(rec, "actuators", "joint_control").values()]
    driven = [b for b in driven if b and f"joints/{b}" in rec.poses] if rec.has_poses else []
    if not driven:
        return None
    fig, axes = plt.subplots(len(driven), 1, figsize=(10, 4 * len(driven)), squeeze=False)
    for ax, body in zip(axes[:, 0], driven, strict=True):
        q = rec.poses[f"joints/{body}"]
        for j, name in enumerate(rec.header["bodies"][body]["joints"]):
            ax.plot(rec.poses["t"], q[:, j], lw=1.2, label=name)
        ax.set_ylabel(f"{body}: joint position (rad)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=2, loc="upper right")
    axes[-1, 0].set_xlabel("sim time (s)")
    axes[0, 0].set_title("joint angles  " + _title(rec))
    return fig


# ----------------------------------------------------------------- lidar
def plot_lidar(rec: RunRecord, plt: Any, at: float | None) -> Any:
    """The first lidar's scan at sim time ``at`` (default: mid-run), re-cast on the recorded scene, polar."""
    from robokit.record.scene import rebuild

    name, spec = next(iter(_of_type(rec, "sensors", "lidar").items()))
    t = rec.poses["t"]
    when = float(t[len(t) // 2]) if at is None else float(at)
    i = int(np.clip(np.searchsorted(t, when + 1e-9, side="right") - 1, 0, len(t) - 1))
    with rebuild(rec) as scene:
        scene.set_frame(i)
        angles, ranges = cast_scan(scene.world, spec)
    fig = plt.figure(figsize=(6, 6))
    ax = fig.add_subplot(projection="polar")
    hit = np.isfinite(ranges)
    ax.scatter(angles[hit], ranges[hit], s=4, color="tab:red", label="return")
    ax.scatter(angles[~hit], np.full((~hit).sum(), float(spec.get("range_max", 5.0))), s=1, color="tab:green",
               alpha=0.4, label="no return (range_max)")
    ax.set_rmax(float(spec.get("range_max", 5.0)))
    ax.legend(loc="lower left", fontsize=7, bbox_to_anchor=(-0.1, -0.12))
    ax.set_title(f"lidar '{name}' at t = {float(t[i]):.2f} s (robot frame, +x ahead)\n" + _title(rec), fontsize=8)
    return fig


def cast_scan(world: Any, spec: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Cast a lidar's rays (its config keys, LaserScan angles) in a posed world, without noise.

    Returns angles (rad, sensor frame, counter-clockwise from +x) and ranges (m, +inf = no return).
    """
    robot, link_name = str(spec.get("robot", "robot")), str(spec.get("link", "lidar_link"))
    rays, fov = int(spec.get("rays", 360)), float(spec.get("fov_deg", 360.0))
    rmin, rmax = float(spec.get("range_min", 0.05)), float(spec.get("range_max", 5.0))
    if math.isclose(fov, 360.0):
        angles = -math.pi + np.arange(rays) * (2 * math.pi / rays)
    else:
        angles = np.linspace(-math.radians(fov) / 2, math.radians(fov) / 2, rays)
    client = world.client
    pos, orn = world.pose(robot, world.link(robot, link_name))
    origin, orn = client.multiplyTransforms(pos, orn, list(spec.get("offset", (0, 0, 0))),
                                            client.getQuaternionFromEuler([0, 0, math.radians(
                                                float(spec.get("yaw_offset_deg", 0.0)))]))
    rot = np.asarray(client.getMatrixFromQuaternion(orn), float).reshape(3, 3)
    dirs = (rot @ np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)])).T
    starts = np.asarray(origin) + dirs * rmin
    ends = np.asarray(origin) + dirs * rmax
    own = world.body(robot)
    group = 0x100  # the robot's links in a group of their own that the rays skip, as the lidar sensor does
    for link in range(-1, client.getNumJoints(own)):
        client.setCollisionFilterGroupMask(own, link, group, -1)
    ranges = np.full(rays, np.inf)
    for k, hit in enumerate(client.rayTestBatch(starts.tolist(), ends.tolist(), collisionFilterMask=-1 ^ group)):
        if hit[0] >= 0 and hit[0] != own:
            ranges[k] = rmin + hit[2] * (rmax - rmin)
    return angles, ranges
