"""The honest yardstick: robokit's main jobs against careful hand-written pybullet loops doing the same job.

Two jobs, each on the scene robokit builds from its config for the same seed:

- **sort** (``configs/sort_robot.toml``): look with the fixed camera (one TinyRenderer frame per look), find the
  red and blue cubes with OpenCV (HSV threshold, opening, connected components, deprojection through the depth
  buffer), pick the one nearest the hand with IK moves along straight lines (``calculateInverseKinematics`` per
  waypoint, seeded with the previous solution; every tick's joint targets interpolated once per move, in numpy, so
  that a tick of the move is one motor command and one step; at the end of each move, one forward-kinematics query
  a tick until the measured end-effector pose has converged, compared by squared distance and quaternion dot
  product), grasp with the coupled fingers (settle on the finger width, verify by finger contacts), place it in its
  colour's tray, look again. The loop is written lean, as a careful author would: no pybullet query it does not
  need (a move reads the arm once at its start and only the tool pose while it settles; a squeeze reads the two
  finger joints a tick; contacts only to verify a grasp), nothing recomputed per tick that a move knows up front.
- **patrol** (``configs/patrol_robot.toml``): a 360-ray lidar at 10 Hz (one ``rayTestBatch``), a differential drive
  at 60 Hz, a 20 Hz navigator (clearance-based avoidance that commits to a side), can discovery from lidar returns
  not explained by the map, a front scoop that stows a can in the bin.

The hand-written side imports neither robokit nor its plugins: it reads the TOML itself and builds the scene with
raw pybullet, drawing from a ``numpy`` generator seeded like robokit's World; the first seed checks that every
body is where robokit puts it. Its decisions follow the same plan as robokit's behaviours, written plainly.

Reported, per job:

- **loop**: wall time of the run loop per simulated second (scene built outside the timing), robokit over
  hand-written, per seed; runs interleaved (the order alternates seed by seed) so both share the machine's load;
  median and spread (min..max, p10..p90) of the per-seed ratios; the same with the process's CPU time, which a
  loaded machine disturbs less than wall time; with ``--pairs K`` each seed runs K interleaved pairs and each
  side's fastest run counts (other tenants of the machine can only slow a run down, so the minimum is the
  steadiest estimate of what the code costs);
- **job**: whole-process wall time of ``robokit run CONFIG --seed N --quiet`` against this script run as a child
  doing the hand-written job for the same seed (imports, scene, loop, result), interleaved;
- success on both sides.

Where Linux lets a process count its own hardware events (``perf_event_open``, see ``benchmarks/_counters.py``),
the loop ratios are also given in user-mode CPU cycles, which a busy machine disturbs far less than wall time, and
in instructions (the work done, the same on any load).

    python benchmarks/handwritten.py --seeds 20                 # both jobs, everything printed
    python benchmarks/handwritten.py --seeds 20 --jobs sort     # one job
    python benchmarks/handwritten.py --seeds 20 --job-seeds 10  # more whole-process runs (default 5)
    python benchmarks/handwritten.py --seeds 20 --pairs 3       # best of 3 interleaved pairs a seed (steadier)
    python benchmarks/handwritten.py --callgrind 3 --jobs sort  # loop instructions under callgrind, seeds 0-2

``--callgrind N`` counts instead of timing: each side's run loop (instrumentation switched on just before the loop
and off after it) runs under valgrind's callgrind in a child process; the ratio is instructions per simulated
second. It needs valgrind, takes about a minute a seed, and does not depend on the machine's load: the figure to
quote on a shared machine without hardware counters.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = ROOT / "configs"
DATA = ROOT / "robokit" / "data"
JOBS = {"sort": CONFIGS / "sort_robot.toml", "patrol": CONFIGS / "patrol_robot.toml"}


def _pybullet() -> Any:
    """pybullet, imported with its build-time banner (printed to C stdout) sent to /dev/null."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        import pybullet
    finally:
        os.dup2(saved, 1)
        os.close(devnull)
        os.close(saved)
    return pybullet


# ============================================================================================ the scene, by hand
class Scene:
    """A raw pybullet client with the config's bodies by name (built the way robokit builds it)."""

    def __init__(self, path: Path, seed: int) -> None:
        p = self.p = _pybullet()
        import pybullet_data

        self.raw = tomllib.loads(path.read_text())
        self.base = path.parent
        world = self.raw.get("world", {})
        self.dt = float(world.get("time_step", 1.0 / 240.0))
        self.max_time = float(world.get("max_time", 60.0))
        self.cid = p.connect(p.DIRECT)
        self.data = pybullet_data.getDataPath()
        p.setAdditionalSearchPath(self.data, physicsClientId=self.cid)
        p.setGravity(*world.get("gravity", (0.0, 0.0, -9.81)), physicsClientId=self.cid)
        p.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSolverIterations=int(world.get("solver_iterations", 50)),
                                    physicsClientId=self.cid)
        self.rng = np.random.default_rng(seed)
        self.bodies: dict[str, int] = {}
        self._spawn_all()

    def _spawn_all(self) -> None:
        groups = {**self.raw.get("bodies", {}), **self.raw.get("robots", {})}
        for name, b in groups.items():
            if "region" not in b:
                self._spawn(name, b, b["position"])
        for rname, reg in self.raw.get("regions", {}).items():
            members = [(n, b) for n, b in groups.items() if b.get("region") == rname]
            total = sum(int(b.get("count", 1)) for _, b in members)
            if total == 0:
                continue
            boxes = [self.body_aabb(self.bodies[a]) for a in reg.get("avoid", [])]
            points = iter(self._sample(total, reg, boxes))
            for n, b in members:
                count = int(b.get("count", 1))
                for i in range(count):
                    x, y = next(points)
                    self._spawn(n if count == 1 else f"{n}_{i}", b, (x, y, float(reg.get("z", 0.0))))

    def _sample(self, count: int, reg: dict[str, Any], boxes: list[Any]) -> list[np.ndarray]:
        lo, hi = np.asarray(reg["low"], float), np.asarray(reg["high"], float)
        spacing, clear = float(reg.get("min_spacing", 0.0)), float(reg.get("clearance", 0.0))
        grown = [(np.asarray(a[:2]) - clear, np.asarray(b[:2]) + clear) for a, b in boxes]
        out: list[np.ndarray] = []
        for _ in range(10_000):
            if len(out) == count:
                break
            cand = self.rng.uniform(lo, hi)
            if any(np.linalg.norm(cand - q) < spacing for q in out):
                continue
            if any(bool(np.all(cand >= a) and np.all(cand <= b)) for a, b in grown):
                continue
            out.append(cand)
        return out

    def _orientation(self, b: dict[str, Any]) -> Any:
        p = self.p
        if "yaw_deg_range" in b:
            roll, pitch, _ = b.get("rpy_deg", (0.0, 0.0, 0.0))
            yaw = float(self.rng.uniform(*b["yaw_deg_range"]))
            return p.getQuaternionFromEuler([math.radians(a) for a in (roll, pitch, yaw)])
        if "quaternion" in b:
            q = np.asarray(b["quaternion"], float)
            return tuple(q / np.linalg.norm(q))
        return p.getQuaternionFromEuler([math.radians(a) for a in b.get("rpy_deg", (0.0, 0.0, 0.0))])

    def _spawn(self, name: str, b: dict[str, Any], position: Any) -> None:
        p, cid = self.p, self.cid
        orn = self._orientation(b)
        pos = [float(v) for v in position]
        if "shape" in b:
            body = self._primitive(b, pos, orn)
        else:
            flags = p.URDF_USE_INERTIA_FROM_FILE | (p.URDF_USE_SELF_COLLISION if b.get("self_collision") else 0)
            body = p.loadURDF(self._urdf(b["urdf"]), pos, orn, useFixedBase=bool(b.get("fixed_base", False)),
                              globalScaling=float(b.get("scale", 1.0)), flags=flags, physicsClientId=cid)
        keys = {"lateral_friction": "lateralFriction", "rolling_friction": "rollingFriction",
                "spinning_friction": "spinningFriction", "restitution": "restitution",
                "linear_damping": "linearDamping", "angular_damping": "angularDamping"}
        dyn = {keys[k]: float(v) for k, v in b.items() if k in keys}
        if dyn:
            p.changeDynamics(body, -1, physicsClientId=cid, **dyn)
        for jname, value in b.get("joint_positions", {}).items():
            p.resetJointState(body, joint_index(p, cid, body, jname), value, physicsClientId=cid)
        self.bodies[name] = body

    def _primitive(self, b: dict[str, Any], pos: list[float], orn: Any) -> int:
        p, cid = self.p, self.cid
        rgba = list(b.get("rgba", (0.7, 0.7, 0.7, 1.0)))
        shape = b["shape"]
        if shape == "box":
            hx, hy, hz = (s / 2.0 for s in b.get("size", (0.1, 0.1, 0.1)))
            if b.get("collision") == "mesh":  # a static box as 12 triangles (corner i: signs of bits 4, 2, 1)
                verts = [[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
                tris = [0, 1, 2, 1, 3, 2, 4, 6, 5, 5, 6, 7, 0, 4, 1, 1, 4, 5,
                        2, 3, 6, 3, 7, 6, 0, 2, 4, 2, 6, 4, 1, 5, 3, 3, 5, 7]
                col = p.createCollisionShape(p.GEOM_MESH, vertices=verts, indices=tris, physicsClientId=cid)
            else:
                col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[hx, hy, hz], physicsClientId=cid)
            vis = p.createVisualShape(p.GEOM_BOX, halfExtents=[hx, hy, hz], rgbaColor=rgba, physicsClientId=cid)
        elif shape == "sphere":
            r = float(b.get("radius", 0.05))
            col = p.createCollisionShape(p.GEOM_SPHERE, radius=r, physicsClientId=cid)
            vis = p.createVisualShape(p.GEOM_SPHERE, radius=r, rgbaColor=rgba, physicsClientId=cid)
        else:
            r, h = float(b.get("radius", 0.05)), float(b.get("height", 0.1))
            col = p.createCollisionShape(p.GEOM_CYLINDER, radius=r, height=h, physicsClientId=cid)
            vis = p.createVisualShape(p.GEOM_CYLINDER, radius=r, length=h, rgbaColor=rgba, physicsClientId=cid)
        return int(p.createMultiBody(baseMass=float(b.get("mass", 1.0)), baseCollisionShapeIndex=col,
                                     baseVisualShapeIndex=vis, basePosition=pos, baseOrientation=list(orn),
                                     physicsClientId=cid))

    def _urdf(self, urdf: str) -> str:
        for cand in (self.base / urdf, DATA / urdf, Path(self.data) / urdf):
            if cand.is_file():
                return str(cand.resolve())
        raise FileNotFoundError(urdf)

    def body_aabb(self, body: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Bounding box of all links of a body, world frame."""
        p = self.p
        boxes = [p.getAABB(body, link, physicsClientId=self.cid)
                 for link in range(-1, p.getNumJoints(body, physicsClientId=self.cid))]
        return (tuple(min(b[0][i] for b in boxes) for i in range(3)),
                tuple(max(b[1][i] for b in boxes) for i in range(3)))

    def close(self) -> None:
        self.p.disconnect(physicsClientId=self.cid)


def joint_index(p: Any, cid: int, body: int, name: str) -> int:
    """Index of a joint by name."""
    for i in range(p.getNumJoints(body, physicsClientId=cid)):
        if p.getJointInfo(body, i, physicsClientId=cid)[1].decode() == name:
            return i
    raise KeyError(name)


def link_index(p: Any, cid: int, body: int, name: str) -> int:
    """Index of a link (the joint whose child it is) by name."""
    for i in range(p.getNumJoints(body, physicsClientId=cid)):
        if p.getJointInfo(body, i, physicsClientId=cid)[12].decode() == name:
            return i
    raise KeyError(name)


# ============================================================================================ sort, by hand
def _quat_angle(a: Any, b: Any) -> float:
    return 2.0 * math.acos(min(1.0, abs(sum(x * y for x, y in zip(a, b, strict=True)))))


def _profile(path: np.ndarray, ticks: int, dt: float, duration: float) -> tuple[list[list[float]], list[list[float]]]:
    """Joint targets and feed-forward velocities for each of ``ticks`` ticks along the waypoints ``path`` (rows),
    on a smooth (zero end-velocity) time profile: computed once per move, as lists ready to send."""
    s = np.clip(np.arange(ticks + 1) * dt / duration, 0.0, 1.0)
    x = s * s * (3.0 - 2.0 * s) * (len(path) - 1)
    i = np.minimum(x.astype(int), len(path) - 2)
    q = path[i] + (x - i)[:, None] * (path[i + 1] - path[i])
    return q[:-1].tolist(), ((q[1:] - q[:-1]) / dt).tolist()


HSV = {"red": [((170, 128, 64), (179, 255, 255)), ((0, 128, 64), (10, 255, 255))],
       "blue": [((100, 128, 64), (130, 255, 255))]}
"""OpenCV HSV ranges (H 0..179) of the two colours that have a tray."""


class HandSort:
    """The sort job in plain pybullet + OpenCV: a generator of ticks driven by :meth:`run`."""

    ARM = [f"panda_joint{i}" for i in range(1, 8)]
    READY = [0.0, -0.9, 0.0, -2.8, 0.0, 1.9, 0.785]
    LOOK = (0.28, 0.0, 0.34)

    def __init__(self, scene: Scene) -> None:
        import cv2

        self.cv2, self.scene, self.p, self.cid = cv2, scene, scene.p, scene.cid
        p, cid = self.p, self.cid
        self.panda = panda = scene.bodies["panda"]
        count = p.getNumJoints(panda, physicsClientId=cid)
        infos = [p.getJointInfo(panda, i, physicsClientId=cid) for i in range(count)]
        self.movable = [i[0] for i in infos if i[2] in (p.JOINT_REVOLUTE, p.JOINT_PRISMATIC)]
        by_name = {i[1].decode(): i for i in infos}
        self.arm = [by_name[n][0] for n in self.ARM]
        self.fingers = [by_name[f"panda_finger_joint{k}"][0] for k in (1, 2)]
        self.ee = link_index(p, cid, panda, "panda_grasptarget")
        self.forces = [by_name[n][10] for n in self.ARM]
        for j, q in zip(self.arm, self.READY, strict=True):
            p.resetJointState(panda, j, q, physicsClientId=cid)
        self.base_com = np.asarray(p.getDynamicsInfo(panda, -1, physicsClientId=cid)[3])
        self.gains, self.zero, self.damping = ([0.3] * 7, [1.0] * 7), [0.0] * 7, [0.01] * len(self.movable)
        self._send(self.READY, self.zero)
        for f in self.fingers:  # friction grasp: grippy fingers, coupled by a gear constraint
            p.changeDynamics(panda, f, lateralFriction=1.2, spinningFriction=0.002, frictionAnchor=True,
                             physicsClientId=cid)
            p.resetJointState(panda, f, 0.04, physicsClientId=cid)
        gear = p.createConstraint(panda, self.fingers[0], panda, self.fingers[1], jointType=p.JOINT_GEAR,
                                  jointAxis=[1, 0, 0], parentFramePosition=[0, 0, 0], childFramePosition=[0, 0, 0],
                                  physicsClientId=cid)
        p.changeConstraint(gear, gearRatio=-1, erp=0.1, maxForce=50, physicsClientId=cid)
        self._grip(0.08)
        cam = scene.raw["sensors"]["camera"]
        self.w, self.h, self.near, self.far = cam["width"], cam["height"], cam["near"], cam["far"]
        self.view = p.computeViewMatrix(cam["eye"], cam["target"], cam["up"], physicsClientId=cid)
        self.proj = p.computeProjectionMatrixFOV(cam["fov"], self.w / self.h, self.near, self.far, physicsClientId=cid)
        vp = np.array(self.proj).reshape(4, 4).T @ np.array(self.view).reshape(4, 4).T
        self.inv_vp = np.linalg.inv(vp)
        self.kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
        self.bins: dict[str, tuple[Any, list[tuple[float, float, float]]]] = {}
        for colour in ("red", "blue"):
            body = scene.bodies[f"{colour}_bin"]
            (bx, by, bz), _ = p.getBasePositionAndOrientation(body, physicsClientId=cid)
            d, z = 0.035, bz + 0.008 + 0.025
            slots = [(bx + ox, by + oy, z) for ox, oy in ((-d, -d), (d, d), (-d, d), (d, -d), (0.0, 0.0))]
            self.bins[colour] = (scene.body_aabb(body), slots)
        self.used = {"red": 0, "blue": 0}
        self.frames = self.picks = self.ticks = 0

    # ------------------------------------------------------------------ devices
    def _send(self, q: Any, qd: Any) -> None:
        self.p.setJointMotorControlArray(self.panda, self.arm, self.p.POSITION_CONTROL, targetPositions=q,
                                         targetVelocities=qd, forces=self.forces, positionGains=self.gains[0],
                                         velocityGains=self.gains[1], physicsClientId=self.cid)

    def _grip(self, width: float, force: float = 20.0) -> None:
        for f in self.fingers:
            self.p.setJointMotorControl2(self.panda, f, self.p.POSITION_CONTROL, targetPosition=width / 2,
                                         force=force, maxVelocity=0.2, physicsClientId=self.cid)

    def _width(self) -> float:
        s = self.p.getJointStates(self.panda, self.fingers, physicsClientId=self.cid)
        return float(s[0][0] + s[1][0])

    def _holding(self) -> bool:
        p, cid = self.p, self.cid
        touched = [{c[2] for c in p.getContactPoints(bodyA=self.panda, linkIndexA=f, physicsClientId=cid)
                    if c[2] != self.panda} for f in self.fingers]
        return bool(touched[0] & touched[1]) and self._width() > 0.004

    def _ee(self) -> tuple[Any, Any]:
        s = self.p.getLinkState(self.panda, self.ee, computeForwardKinematics=1, physicsClientId=self.cid)
        return s[4], s[5]

    # ------------------------------------------------------------------ motions
    def move(self, pos: tuple[float, float, float], yaw: float, speed: float) -> bool:
        """Straight Cartesian line to ``pos`` (tool down, ``yaw``): IK per 2.5 cm waypoint, joint targets for every
        tick interpolated once (numpy) and sent each tick, then wait until the measured pose is within 5 mm /
        0.05 rad (1 s allowed)."""
        p, cid, dt = self.p, self.cid, self.scene.dt
        orn = p.getQuaternionFromEuler((math.pi, 0.0, yaw))
        start, start_orn = self._ee()
        dist, ang = math.dist(start, pos), _quat_angle(start_orn, orn)
        n = max(1, math.ceil(dist / 0.025), math.ceil(ang / 0.15))
        q = [s[0] for s in p.getJointStates(self.panda, self.movable, physicsClientId=cid)]
        path = [q[:7]]
        s_, e_ = np.asarray(start), np.asarray(pos)
        for k in range(1, n + 1):
            s = k / n
            # pybullet's IK works in the base's inertial frame (5 cm above the Panda's URDF origin): shift the target
            q = list(p.calculateInverseKinematics(self.panda, self.ee, list(s_ + s * (e_ - s_) - self.base_com),
                                                  p.getQuaternionSlerp(start_orn, orn, s), jointDamping=self.damping,
                                                  maxNumIterations=20, residualThreshold=1e-5, currentPositions=q,
                                                  physicsClientId=cid))
            path.append(q[:7])
        duration = max(1.5 * dist / speed, 1.5 * ang / 3.0, 0.05)
        targets, velocities = _profile(np.array(path), math.ceil(duration / dt), dt, duration)
        send, step, control = p.setJointMotorControlArray, p.stepSimulation, p.POSITION_CONTROL
        panda, arm, forces, (kp, kd) = self.panda, self.arm, self.forces, self.gains
        for q_k, qd_k in zip(targets, velocities, strict=True):
            send(panda, arm, control, targetPositions=q_k, targetVelocities=qd_k, forces=forces, positionGains=kp,
                 velocityGains=kd, physicsClientId=cid)
            step(physicsClientId=cid)
        self.ticks += len(targets)
        self._send(path[-1], self.zero)
        return self._settle(pos, orn)

    def _settle(self, pos: tuple[float, float, float], orn: Any) -> bool:
        """Step until the measured tool pose is within 5 mm and 0.05 rad of the target (1 s allowed): one forward-
        kinematics query a tick, compared without roots or trigonometry (squared distance, quaternion dot product)."""
        p, cid, panda, ee = self.p, self.cid, self.panda, self.ee
        x, y, z = pos
        qx, qy, qz, qw = orn
        cos_half = math.cos(0.05 / 2.0)  # angle <= 0.05 rad  <=>  |q . q_target| >= cos(0.025)
        for _ in range(round(1.0 / self.scene.dt)):
            s = p.getLinkState(panda, ee, computeForwardKinematics=1, physicsClientId=cid)
            (hx, hy, hz), (ax, ay, az, aw) = s[4], s[5]
            if ((hx - x) ** 2 + (hy - y) ** 2 + (hz - z) ** 2 <= 0.005 ** 2
                    and abs(ax * qx + ay * qy + az * qz + aw * qw) >= cos_half):
                return True
            p.stepSimulation(physicsClientId=cid)
            self.ticks += 1
        return False

    def squeeze(self, width: float, wait_open: float | None = None) -> None:
        """Command the fingers, then step until the width has been still (< 1 cm/s) for 0.04 s (1 s allowed)."""
        p, cid, panda, fingers, dt = self.p, self.cid, self.panda, self.fingers, self.scene.dt
        self._grip(width)
        last, still = self._width(), 0
        for k in range(round(1.0 / dt)):
            p.stepSimulation(physicsClientId=cid)
            self.ticks += 1
            a, b = p.getJointStates(panda, fingers, physicsClientId=cid)
            w = a[0] + b[0]
            if wait_open is not None and w >= wait_open:
                return
            still = still + 1 if abs(w - last) / dt <= 0.01 else 0
            last = w
            if still * dt >= 0.04 and k >= 5:
                return

    # ------------------------------------------------------------------ perception
    def look(self) -> list[tuple[str, tuple[float, float, float], float]]:
        """One frame: (colour, object centre in metres, yaw) of each red or blue blob outside the trays."""
        p, cv2 = self.p, self.cv2
        self.frames += 1
        _, _, rgba, depth, _ = p.getCameraImage(self.w, self.h, viewMatrix=self.view, projectionMatrix=self.proj,
                                                renderer=p.ER_TINY_RENDERER, flags=p.ER_NO_SEGMENTATION_MASK,
                                                shadow=0, physicsClientId=self.cid)
        rgb = np.asarray(rgba, np.uint8).reshape(self.h, self.w, 4)[:, :, :3]
        zbuf = np.asarray(depth, np.float32).reshape(self.h, self.w)
        hsv = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2HSV)
        found = []
        for colour, spans in HSV.items():
            mask = np.zeros((self.h, self.w), np.uint8)
            for lo, hi in spans:
                mask |= cv2.inRange(hsv, np.array(lo, np.uint8), np.array(hi, np.uint8))
            if not cv2.countNonZero(mask):
                continue
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, self.kernel)
            count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
            for i in range(1, count):
                if stats[i, cv2.CC_STAT_AREA] < 30:
                    continue
                v, u = np.nonzero(labels == i)
                pts = self._deproject(u, v, zbuf[v, u])
                top = pts[pts[:, 2] >= np.percentile(pts[:, 2], 98) - 0.006]
                (cx, cy), _, angle = cv2.minAreaRect(top[:, :2].astype(np.float32))
                centre = (float(cx), float(cy), float(np.median(top[:, 2])) - 0.025)
                (lo_, hi_), _ = self.bins[colour]
                if lo_[0] - 0.02 <= cx <= hi_[0] + 0.02 and lo_[1] - 0.02 <= cy <= hi_[1] + 0.02:
                    continue  # already in its tray
                found.append((colour, centre, math.radians((angle + 45.0) % 90.0 - 45.0)))
        return found

    def _deproject(self, u: np.ndarray, v: np.ndarray, d: np.ndarray) -> np.ndarray:
        ndc = np.stack([2.0 * u / self.w - 1.0, 1.0 - 2.0 * (v + 1.0) / self.h, 2.0 * d - 1.0, np.ones(len(u))])
        world = self.inv_vp @ ndc
        return (world[:3] / world[3]).T

    # ------------------------------------------------------------------ the job
    def pick_place(self, colour: str, pos: tuple[float, float, float], yaw: float) -> bool:
        """Approach, descend, grasp, lift, carry, lower, release, retreat; False as soon as a step fails."""
        self.picks += 1
        _, slots = self.bins[colour]
        place = slots[self.used[colour] % len(slots)]
        self.used[colour] += 1
        yaw = yaw + round((0.0 - yaw) / (math.pi / 2)) * math.pi / 2  # the cube's 90-degree symmetry
        x, y, z = pos
        self._grip(0.08)
        altitude = max(z, place[2]) + 0.08
        if not self.move((x, y, z + 0.07), yaw, 1.2) or not self.move((x, y, z), yaw, 0.6):
            return False
        self.squeeze(0.0)
        if not self._holding():
            return False
        if not self.move((x, y, altitude), yaw, 1.2) or not self._holding():
            return False
        if not self.move((place[0], place[1], altitude), yaw, 1.2) or not self._holding():
            return False
        if not self.move((place[0], place[1], place[2] + 0.004), yaw, 0.6):
            return False
        self.squeeze(0.075, wait_open=0.06)
        return self.move((place[0], place[1], place[2] + 0.05), yaw, 1.2)

    def run(self) -> dict[str, Any]:
        """Look, pick the nearest sortable cube, place it, look again; until nothing is left (or 30 picks)."""
        limit = round(self.scene.max_time / self.scene.dt)
        while self.ticks < limit and self.picks < 30:
            seen = self.look()
            if not seen:
                break
            hand = self._ee()[0]
            colour, pos, yaw = min(seen, key=lambda d: math.dist(hand[:2], d[1][:2]))
            if not self.pick_place(colour, pos, yaw):
                self._grip(0.08)
                self.move(self.LOOK, 0.0, 1.2)
        return {"sorted": self.sorted_count(), "picks": self.picks, "frames": self.frames,
                "sim_time": self.ticks * self.scene.dt}

    def sorted_count(self) -> int:
        """Cubes whose true position lies over their colour's tray (the report's truth, not a decision)."""
        n = 0
        for name, body in self.scene.bodies.items():
            colour = name.split("_")[0]
            if colour in self.bins and name != f"{colour}_bin":
                (x, y, _), _ = self.p.getBasePositionAndOrientation(body, physicsClientId=self.cid)
                (lo, hi), _ = self.bins[colour]
                n += lo[0] <= x <= hi[0] and lo[1] <= y <= hi[1]
        return n


# ============================================================================================ patrol, by hand
def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def clear_along(pts: np.ndarray, angles: np.ndarray, corridor: float, far: float) -> np.ndarray:
    """How far a disk of radius ``corridor`` moves along each heading (robot frame) before touching a point."""
    if len(pts) == 0:
        return np.full(len(angles), far)
    ux, uy = np.cos(angles), np.sin(angles)
    along = np.outer(pts[:, 0], ux) + np.outer(pts[:, 1], uy)
    side = np.abs(np.outer(pts[:, 0], uy) - np.outer(pts[:, 1], ux))
    blocked = (side < corridor) & (along > 0.0)
    gap = along - np.sqrt(np.maximum(corridor**2 - side**2, 0.0))
    return np.asarray(np.where(blocked, np.maximum(gap, 0.0), far).min(axis=0))


class HandPatrol:
    """The patrol-and-collect job in plain pybullet + numpy: lidar 10 Hz, drive 60 Hz, decisions 20 Hz."""

    SCAN, DRIVE, DECIDE = 24, 4, 12  # ticks between lidar scans, wheel updates, decisions (and scoop checks)

    def __init__(self, scene: Scene, seed: int) -> None:
        self.scene, self.p, self.cid = scene, scene.p, scene.cid
        p, cid = self.p, self.cid
        raw = scene.raw
        self.robot = robot = scene.bodies["robot"]
        self.wheels = [joint_index(p, cid, robot, n) for n in ("left_wheel", "right_wheel")]
        p.setJointMotorControl2(robot, joint_index(p, cid, robot, "caster_wheel"), p.VELOCITY_CONTROL,
                                targetVelocity=0.0, force=0.0, physicsClientId=cid)
        self.lidar = link_index(p, cid, robot, "lidar_link")
        self.bin = link_index(p, cid, robot, "bin_link")
        for link in range(-1, p.getNumJoints(robot, physicsClientId=cid)):  # rays skip the robot's own links
            p.setCollisionFilterGroupMask(robot, link, 0x100, -1, physicsClientId=cid)
        ang = -math.pi + (2.0 * math.pi / 360) * np.arange(360)
        self.local_dirs = np.stack([np.cos(ang), np.sin(ang), np.zeros(360)], axis=1)
        self.noise = np.random.default_rng([seed, 15])
        beh = raw["behaviour"]
        self.waypoints = [tuple(w) for w in beh["waypoints"]]
        self.map_names = set(beh["map_bodies"])
        boxes = [scene.body_aabb(scene.bodies[n]) for n in beh["map_bodies"]]
        self.map = np.array([[lo[0] - 0.08, lo[1] - 0.08, hi[0] + 0.08, hi[1] + 0.08] for lo, hi in boxes])
        self.cans = {n: b for n, b in scene.bodies.items() if n.startswith("can_")}
        self.headings = -math.pi + (2.0 * math.pi / 72) * np.arange(72)
        self.speeds, self.targets = [0.0, 0.0], [0.0, 0.0]
        self.tracks: list[dict[str, Any]] = []
        self.held: list[str] = []
        self.armed = False
        self.touching: set[str] = set()
        self.collisions = self.ticks = 0
        self.scan_pts = np.zeros((0, 2))
        self.origin = np.zeros(3)
        self._reset_nav()

    # ------------------------------------------------------------------ devices
    def _pose(self) -> tuple[float, float, float]:
        (x, y, _), orn = self.p.getBasePositionAndOrientation(self.robot, physicsClientId=self.cid)
        return x, y, self.p.getEulerFromQuaternion(orn)[2]

    def scan(self) -> None:
        """One 360-ray scan from the lidar link; keeps the hit points (world xy, above the floor) and ranges."""
        p, cid = self.p, self.cid
        s = p.getLinkState(self.robot, self.lidar, computeForwardKinematics=1, physicsClientId=cid)
        origin, rot = np.asarray(s[4]), np.asarray(p.getMatrixFromQuaternion(s[5])).reshape(3, 3)
        dirs = self.local_dirs @ rot.T
        lo, hi = self.scene.body_aabb(self.robot)
        lo_, hi_ = np.asarray(lo) - 0.03, np.asarray(hi) + 0.03
        with np.errstate(divide="ignore"):
            inv = 1.0 / dirs
        near = np.maximum(0.05, np.maximum((hi_ - origin) * inv, (lo_ - origin) * inv).min(axis=1))
        res = p.rayTestBatch(origin + dirs * near[:, None], origin + dirs * 5.0, numThreads=1,
                             collisionFilterMask=-1 ^ 0x100, physicsClientId=cid)
        ids = np.fromiter((r[0] for r in res), int, 360)
        frac = np.fromiter((r[2] for r in res), float, 360)
        rng = np.clip(near + frac * (5.0 - near) + self.noise.normal(0.0, 0.01, 360), 0.05, 5.0)
        hit = ids >= 0
        pts = origin + dirs * rng[:, None]
        keep = hit & (pts[:, 2] > 0.03)
        self.scan_pts, self.scan_rng, self.origin = pts[keep, :2], rng[keep], origin

    def drive(self) -> None:
        """Ramp the wheel speeds towards the targets (2 m/s^2 at the rim) and send them."""
        step = 2.0 / 0.05 * self.DRIVE * self.scene.dt
        self.speeds = [s + max(-step, min(step, t - s)) for s, t in zip(self.speeds, self.targets, strict=True)]
        self.p.setJointMotorControlArray(self.robot, self.wheels, self.p.VELOCITY_CONTROL,
                                         targetVelocities=self.speeds, forces=[5.0, 5.0], physicsClientId=self.cid)

    def twist(self, v: float, w: float) -> None:
        left, right = (v - 0.13 * w) / 0.05, (v + 0.13 * w) / 0.05
        scale = min(1.0, 20.0 / max(abs(left), abs(right), 1e-9))
        self.targets = [left * scale, right * scale]

    def scoop(self) -> None:
        """Armed: stow the first can whose centre is in the reach zone in front of the robot."""
        p, cid = self.p, self.cid
        x0, y0, yaw = self._pose()
        rz = p.getBasePositionAndOrientation(self.robot, physicsClientId=cid)[0][2]
        c, s = math.cos(yaw), math.sin(yaw)
        for name, body in self.cans.items():
            if name in self.held:
                continue
            (x, y, z), _ = p.getBasePositionAndOrientation(body, physicsClientId=cid)
            fx, fy = c * (x - x0) + s * (y - y0), -s * (x - x0) + c * (y - y0)
            if 0.12 <= fx <= 0.30 and abs(fy) <= 0.12 and z - rz < 0.3:
                p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=cid)
                local = [0.04 * (len(self.held) % 3 - 1), 0.0, 0.105]
                bs = p.getLinkState(self.robot, self.bin, computeForwardKinematics=1, physicsClientId=cid)
                at, _ = p.multiplyTransforms(bs[4], bs[5], local, [0, 0, 0, 1])
                p.resetBasePositionAndOrientation(body, at, bs[5], physicsClientId=cid)
                p.createConstraint(self.robot, self.bin, body, -1, p.JOINT_FIXED, [0, 0, 0], local, [0, 0, 0],
                                   physicsClientId=cid)
                self.held.append(name)
                self.collected_at = (x, y)
                return

    def bumps(self) -> None:
        names = {self.scene_names.get(c[2], "") for c in
                 self.p.getContactPoints(bodyA=self.robot, physicsClientId=self.cid)} & self.map_names
        self.collisions += len(names - self.touching)
        self.touching = names

    # ------------------------------------------------------------------ decisions
    def _reset_nav(self) -> None:
        self.side, self.commit, self.best, self.best_at, self.turning = 0, math.inf, math.inf, 0.0, True

    def navigate(self, goal: tuple[float, float], t: float, ignore: tuple[float, float, float] | None = None) -> float:
        """Turn to the goal, drive, or follow an obstacle on the committed side; returns the distance left."""
        x, y, yaw = self._pose()
        dx, dy = goal[0] - x, goal[1] - y
        dist, bearing = math.hypot(dx, dy), _wrap(math.atan2(dy, dx) - yaw)
        pts = self.scan_pts
        if ignore is not None and len(pts):
            pts = pts[np.hypot(pts[:, 0] - ignore[0], pts[:, 1] - ignore[1]) > ignore[2]]
        c, s = math.cos(yaw), math.sin(yaw)
        d = pts - np.array([x, y])
        local = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)
        if dist < self.best - 0.1:
            self.best, self.best_at = dist, t
        elif t - self.best_at > 20.0:  # stalled: try the other side
            self.side, self.commit, self.best, self.best_at = -self.side, dist, dist, t
        goal_clear = float(clear_along(local, np.array([bearing]), 0.26, 5.0)[0])
        if self.side and (goal_clear >= min(dist, 2.0)
                          or (dist < self.commit - 0.05 and goal_clear >= min(dist, 0.7))):
            self.side = 0
        if self.side == 0 and goal_clear >= min(dist, 0.7):
            heading = bearing
        else:
            clear = clear_along(local, self.headings, 0.38, 5.0)
            free = clear >= 0.7
            if not free.any():
                heading = float(self.headings[int(np.argmax(clear))])
            else:
                if self.side == 0:
                    off = (self.headings - bearing) % (2.0 * math.pi)
                    self.side = 1 if np.where(free, off, np.inf).min() <= np.where(free, 2 * math.pi - off,
                                                                                     np.inf).min() else -1
                    self.commit = dist
                start = bearing
                if len(local):
                    r = np.hypot(local[:, 0], local[:, 1])
                    i = int(np.argmin(r))
                    if r[i] < 1.0:
                        start = math.atan2(local[i, 1], local[i, 0])
                off = ((self.headings - start) * self.side) % (2.0 * math.pi)
                heading = float(self.headings[int(np.argmin(np.where(free, off, np.inf)))])
        err = _wrap(heading)
        if self.turning and abs(bearing) < math.radians(20) or self.side:
            self.turning = False
        elif not self.turning and abs(bearing) > math.radians(50) and dist > 0.2 and not self.side:
            self.turning = True
        ahead = float(clear_along(local, np.array([0.0]), 0.26, 5.0)[0])
        w = max(-1.5, min(1.5, 2.5 * err))
        v = 0.0 if self.turning else 0.4 * (math.cos(err) ** 2 if abs(err) < math.pi / 2 else 0.0)
        v = min(v * max(0.0, min(1.0, (ahead - 0.03) / 0.47)), dist + 0.03)
        self.twist(v, w)
        return dist

    def discover(self) -> None:
        """Returns that the map does not explain, in small clusters, become tracks; 3 sightings confirm one."""
        pts = self.scan_pts[self.scan_rng <= 3.5]
        if len(pts) and len(self.map):
            b = self.map
            inside = ((pts[:, None, 0] >= b[:, 0]) & (pts[:, None, 0] <= b[:, 2])
                      & (pts[:, None, 1] >= b[:, 1]) & (pts[:, None, 1] <= b[:, 3])).any(axis=1)
            pts = pts[~inside]
        if len(pts) == 0:
            return
        runs = np.split(pts, np.nonzero(np.hypot(*np.diff(pts, axis=0).T) > 0.1)[0] + 1)
        if len(runs) > 1 and math.dist(pts[0], pts[-1]) <= 0.1:
            runs[0] = np.vstack([runs.pop(), runs[0]])
        for run in runs:
            if len(run) < 2 or math.hypot(*(run.max(axis=0) - run.min(axis=0))) > 0.25:
                continue
            mean = run.mean(axis=0)
            away = mean - self.origin[:2]
            cx, cy = mean + 0.05 * away / max(float(np.linalg.norm(away)), 1e-9)
            near = [tr for tr in self.tracks if math.hypot(tr["x"] - cx, tr["y"] - cy) < 0.3]
            if not near:
                self.tracks.append({"x": cx, "y": cy, "w": 1.0, "n": 1, "status": "seen", "tries": 0})
                continue
            tr = min(near, key=lambda tr: math.hypot(tr["x"] - cx, tr["y"] - cy))
            if tr["status"] == "collected":
                continue
            tr["x"], tr["y"] = (tr["w"] * tr["x"] + cx) / (tr["w"] + 1), (tr["w"] * tr["y"] + cy) / (tr["w"] + 1)
            tr["w"], tr["n"] = min(tr["w"] + 1, 20.0), tr["n"] + 1
            if tr["status"] == "seen" and tr["n"] >= 3:
                tr["status"] = "found"

    def _pending(self) -> dict[str, Any] | None:
        x, y, _ = self._pose()
        todo = [tr for tr in self.tracks if tr["status"] == "found" and tr["tries"] < 2]
        return min(todo, key=lambda tr: math.hypot(tr["x"] - x, tr["y"] - y), default=None)

    # ------------------------------------------------------------------ the job
    def run(self) -> dict[str, Any]:
        """Patrol the waypoints; approach and scoop every can found; finish when all legs are done."""
        dt, limit = self.scene.dt, round(self.scene.max_time / self.scene.dt)
        self.scene_names = {b: n for n, b in self.scene.bodies.items()}
        leg, reached, leg_start, target, since = 0, 0, 0.0, None, 0.0
        done = False
        while self.ticks < limit and not done:
            k, t = self.ticks, self.ticks * dt
            if k % self.SCAN == 0:
                self.scan()
                self.discover()
            if k % self.DECIDE == 0:
                self.bumps()
                if target is not None:
                    if len(self.held) > sum(tr["status"] == "collected" for tr in self.tracks):
                        cx, cy = self.collected_at
                        near = min(self.tracks, key=lambda tr: math.hypot(tr["x"] - cx, tr["y"] - cy))
                        near["status"], target = "collected", None
                    elif t - since > 30.0:
                        target["status"] = "found" if target["tries"] < 2 else "abandoned"
                        target = None
                    if target is None:
                        self.armed = False
                        self.twist(0.0, 0.0)
                        self._reset_nav()
                        leg_start = t
                    else:
                        self.navigate((target["x"], target["y"]), t, (target["x"], target["y"], 0.17))
                else:
                    target = self._pending()
                    if target is not None:
                        target["tries"] += 1
                        since, self.armed = t, True
                        self._reset_nav()
                    elif leg >= len(self.waypoints):
                        done = True
                        self.twist(0.0, 0.0)
                    else:
                        dist = self.navigate(self.waypoints[leg], t)
                        if dist <= 0.2 or t - leg_start > 90.0:
                            reached += dist <= 0.2
                            leg, leg_start = leg + 1, t
                            self._reset_nav()
                if self.armed:
                    self.scoop()
            if k % self.DRIVE == 0:
                self.drive()
            self.p.stepSimulation(physicsClientId=self.cid)
            self.ticks += 1
        return {"waypoints": reached, "waypoints_total": len(self.waypoints), "collected": len(self.held),
                "collisions": self.collisions, "sim_time": self.ticks * dt}


# ============================================================================================ harness
HAND_JOBS: dict[str, Callable[..., Any]] = {"sort": lambda scene, seed: HandSort(scene), "patrol": HandPatrol}


def hand_run(job: str, seed: int) -> dict[str, Any]:
    """Build the scene by hand, run the hand-written job; loop wall seconds, sim seconds and the job's result."""
    scene = Scene(JOBS[job], seed)
    try:
        runner = HAND_JOBS[job](scene, seed)
        _callgrind(True)
        t0, c0, k0, i0 = time.perf_counter(), time.process_time(), _cycles(), _instructions()
        result = runner.run()
        wall, cpu, cycles = time.perf_counter() - t0, time.process_time() - c0, _cycles() - k0
        instr = _instructions() - i0
        _callgrind(False)
    finally:
        scene.close()
    return {"wall": wall, "cpu": cpu, "cycles": cycles, "instr": instr, "sim": result["sim_time"],
            "ok": _hand_ok(job, result),
            "result": result}


UNDER_CALLGRIND: list[bool] = []
"""Set (``--callgrind-child``) when this process runs under valgrind's callgrind with instrumentation off at start."""


def _callgrind(on: bool) -> None:
    """Under callgrind: switch instrumentation on just before a run loop and off just after it (scene building,
    imports and teardown are not counted). Elsewhere: nothing."""
    if UNDER_CALLGRIND:
        subprocess.run(["callgrind_control", "--instr=on" if on else "--instr=off", str(os.getpid())], check=True,
                       stdout=subprocess.DEVNULL)


def _count_loop(job: str, side: str, seed: int, folder: str) -> tuple[int, float, bool]:
    """One side's run loop for one seed in a child process under callgrind: (instructions, sim seconds, success)."""
    out = os.path.join(folder, f"callgrind.{side}.{seed}")
    env = {**os.environ, "PYTHONHASHSEED": "0", "OPENBLAS_NUM_THREADS": "1"}
    cmd = ["valgrind", "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={out}", sys.executable,
           str(Path(__file__).resolve()), "--child", job, "--side", side, "--seed", str(seed), "--callgrind-child"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    found = [line.split()[-1] for line in proc.stderr.splitlines() if "Collected :" in line]
    if proc.returncode != 0 or not found:
        raise SystemExit(f"callgrind run of the {side} side failed ({proc.returncode}): {proc.stderr.strip()[-300:]}")
    data = json.loads(proc.stdout.strip().splitlines()[-1])
    return int(found[-1].replace(",", "")), float(data["sim"]), bool(data["ok"])


def instruction_ratios(job: str, seeds: list[int]) -> None:
    """Each side's run loop counted by callgrind (instructions executed: the same on any load, no hardware counters
    needed), per seed in child processes two at a time; robokit over hand-written per simulated second."""
    from concurrent.futures import ThreadPoolExecutor

    check_scene(job, seeds[0])
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(2) as pool:
        runs = {(side, seed): pool.submit(_count_loop, job, side, seed, tmp)
                for seed in seeds for side in ("robokit", "hand")}
        ratios, ok = [], {"robokit": 0, "hand": 0}
        for seed in seeds:
            (rk, rk_sim, rk_ok), (hw, hw_sim, hw_ok) = runs["robokit", seed].result(), runs["hand", seed].result()
            ratios.append((rk / rk_sim) / (hw / hw_sim))
            ok["robokit"] += rk_ok
            ok["hand"] += hw_ok
            print(f"  {job} seed {seed:3d}: robokit {rk / 1e6:8.1f} M instructions / {rk_sim:6.2f} sim s "
                  f"= {rk / rk_sim / 1e6:6.1f} M/s {'ok' if rk_ok else 'FAIL'} | hand {hw / 1e6:8.1f} M / "
                  f"{hw_sim:6.2f} s = {hw / hw_sim / 1e6:6.1f} M/s {'ok' if hw_ok else 'FAIL'} | "
                  f"ratio {ratios[-1]:.3f}", flush=True)
    print(f"{job} loop, instructions per sim second (callgrind), robokit / hand-written: {_stats(ratios)}")
    print(f"{job} success: robokit {ok['robokit']}/{len(seeds)}, hand-written {ok['hand']}/{len(seeds)}", flush=True)


_COUNTERS: list[Any] = []


def _cycles() -> int:
    """User-mode CPU cycles of this process so far (0 where hardware counters are unavailable)."""
    if not _COUNTERS:
        from _counters import Counters

        _COUNTERS.append(Counters.open())
    return _COUNTERS[0].read()[0] if _COUNTERS[0] is not None else 0


def _instructions() -> int:
    """User-mode instructions of this process so far (0 where hardware counters are unavailable)."""
    _cycles()
    return _COUNTERS[0].read()[1] if _COUNTERS[0] is not None else 0


def _hand_ok(job: str, result: dict[str, Any]) -> bool:
    if job == "sort":
        return bool(result["sorted"] == 4)
    return bool(result["waypoints"] == result["waypoints_total"] and result["collected"] == 4
                and result["collisions"] == 0)


OVERRIDES: dict[str, Any] = {}
"""Dotted config keys set on robokit's side of the loop comparison (``--set``), e.g. a lidar option."""


def _override(text: str) -> tuple[str, Any]:
    """``key=value`` with a TOML value (``sensors.scan.num_threads=0``, ``behaviour.hold_check_hz=240.0``)."""
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    try:
        return key.strip(), tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        return key.strip(), value


def robokit_run(job: str, seed: int) -> dict[str, Any]:
    """Build robokit's simulation for the config and seed; time its run loop."""
    from robokit.testing import make_sim

    with make_sim(str(JOBS[job]), seed=seed, overrides=dict(OVERRIDES) or None) as sim:
        _callgrind(True)
        t0, c0, k0, i0 = time.perf_counter(), time.process_time(), _cycles(), _instructions()
        result = sim.run()
        wall, cpu, cycles = time.perf_counter() - t0, time.process_time() - c0, _cycles() - k0
        instr = _instructions() - i0
        _callgrind(False)
    r = result.result
    if job == "sort":
        ok = result.outcome == "succeeded" and r.get("red_sorted", 0) + r.get("blue_sorted", 0) == 4
    else:
        ok = result.outcome == "succeeded" and r.get("objects_collected") == 4 and r.get("collisions") == 0
    return {"wall": wall, "cpu": cpu, "cycles": cycles, "instr": instr, "sim": result.sim_time, "ok": ok, "result": r}


def check_scene(job: str, seed: int) -> None:
    """Fail loudly unless the hand-built scene has every body exactly where robokit puts it."""
    from robokit.testing import make_sim

    scene = Scene(JOBS[job], seed)
    try:
        with make_sim(str(JOBS[job]), seed=seed) as sim:
            w = sim.world
            assert sorted(scene.bodies) == sorted(w.body_names), (sorted(scene.bodies), w.body_names)
            for name, body in scene.bodies.items():
                mine = scene.p.getBasePositionAndOrientation(body, physicsClientId=scene.cid)
                theirs = w.client.getBasePositionAndOrientation(w.body(name))
                assert np.allclose(mine[0], theirs[0], atol=1e-12) and np.allclose(mine[1], theirs[1], atol=1e-12), \
                    f"{job}: body {name!r} differs: {mine} vs {theirs}"
    finally:
        scene.close()


def _stats(ratios: list[float]) -> str:
    qs = np.percentile(ratios, [10, 90])
    return (f"median {statistics.median(ratios):.3f}  (p10..p90 {qs[0]:.3f}..{qs[1]:.3f}, "
            f"min..max {min(ratios):.3f}..{max(ratios):.3f}, n = {len(ratios)})")


def _best_of(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """The fastest of repeated runs of one side for one seed: each measure's minimum (noise only ever adds time).

    The runs are deterministic, so their sim time and success must agree; a disagreement is a bug, raised loudly."""
    first = runs[0]
    for other in runs[1:]:
        if other["sim"] != first["sim"] or other["ok"] != first["ok"]:
            raise SystemExit(f"repeated runs differ: sim {first['sim']} / {other['sim']} s, "
                             f"ok {first['ok']} / {other['ok']}")
    best = dict(first)
    for key in ("wall", "cpu", "cycles", "instr"):
        best[key] = min(r[key] for r in runs)
    return best


def loop_ratios(job: str, seeds: list[int], pairs: int = 1) -> None:
    """Interleaved in-process runs: per-seed ratio of wall seconds per sim second; success on both sides.

    With ``pairs`` > 1 each seed runs that many interleaved pairs (the order turned round each time) and each side's
    fastest run is compared: on a shared machine a run can only be slowed by others, never sped up."""
    check_scene(job, seeds[0])
    ratios, cpu_ratios, cycle_ratios, instr_ratios, rk_ok, hw_ok, rk_us, hw_us = [], [], [], [], 0, 0, [], []
    for i, seed in enumerate(seeds):
        runs: dict[str, list[dict[str, Any]]] = {"robokit": [], "hand": []}
        for k in range(pairs):
            order = ("robokit", "hand") if (i + k) % 2 == 0 else ("hand", "robokit")
            for side in order:
                runs[side].append((robokit_run if side == "robokit" else hand_run)(job, seed))
        rk, hw = _best_of(runs["robokit"]), _best_of(runs["hand"])
        rk_rate, hw_rate = rk["wall"] / rk["sim"], hw["wall"] / hw["sim"]
        ratios.append(rk_rate / hw_rate)
        cpu_ratios.append((rk["cpu"] / rk["sim"]) / (hw["cpu"] / hw["sim"]))
        if hw["cycles"] > 0:
            cycle_ratios.append((rk["cycles"] / rk["sim"]) / (hw["cycles"] / hw["sim"]))
            instr_ratios.append((rk["instr"] / rk["sim"]) / (hw["instr"] / hw["sim"]))
        rk_ok += rk["ok"]
        hw_ok += hw["ok"]
        dt = 1.0 / 240.0
        rk_us.append(rk_rate * dt * 1e6)
        hw_us.append(hw_rate * dt * 1e6)
        print(f"  {job} seed {seed:3d}: robokit {rk['sim']:6.2f} sim s {rk_us[-1]:6.1f} us/tick "
              f"{'ok' if rk['ok'] else 'FAIL'} | hand {hw['sim']:6.2f} sim s {hw_us[-1]:6.1f} us/tick "
              f"{'ok' if hw['ok'] else 'FAIL'} | ratio {ratios[-1]:.3f} (CPU {cpu_ratios[-1]:.3f}"
              + (f", cycles {cycle_ratios[-1]:.3f})" if cycle_ratios else ")"), flush=True)
    best = f", each side's best of {pairs} interleaved runs a seed" if pairs > 1 else ""
    print(f"{job} loop, wall per sim second, robokit / hand-written{best}: {_stats(ratios)}")
    print(f"{job} loop, process CPU per sim second (steadier on a loaded machine): {_stats(cpu_ratios)}")
    if cycle_ratios:
        print(f"{job} loop, user-mode CPU cycles per sim second (hardware counters, nearly load-independent): "
              f"{_stats(cycle_ratios)}")
        print(f"{job} loop, user-mode instructions per sim second (work done, independent of the machine's load): "
              f"{_stats(instr_ratios)}")
    print(f"{job} per tick (median): robokit {statistics.median(rk_us):.1f} us, "
          f"hand-written {statistics.median(hw_us):.1f} us")
    print(f"{job} success: robokit {rk_ok}/{len(seeds)}, hand-written {hw_ok}/{len(seeds)}", flush=True)


def job_ratios(job: str, seeds: list[int]) -> None:
    """Whole processes, interleaved: ``robokit run`` against this script's hand-written child, per seed."""
    exe = Path(sys.executable).parent / "robokit"
    ratios: list[float] = []
    walls: dict[str, list[float]] = {"robokit": [], "hand": []}
    # Both sides as a user's machine runs them: bytecode caches written and used (a shell with
    # PYTHONDONTWRITEBYTECODE set would compile robokit's ~50 modules on every start); one warm-up round first.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    with tempfile.TemporaryDirectory() as tmp:
        for i, seed in enumerate([seeds[0], *seeds]):
            cmds = {"robokit": [str(exe), "run", str(JOBS[job]), "--seed", str(seed), "--quiet"],
                    "hand": [sys.executable, str(Path(__file__).resolve()), "--child", job, "--seed", str(seed)]}
            order = ("robokit", "hand") if i % 2 == 0 else ("hand", "robokit")
            took = {}
            for side in order:
                t0 = time.perf_counter()
                proc = subprocess.run(cmds[side], cwd=tmp, capture_output=True, text=True, env=env)
                took[side] = time.perf_counter() - t0
                if side == "robokit" and proc.returncode not in (0, 1):
                    raise SystemExit(f"robokit run failed ({proc.returncode}): {proc.stderr.strip()[-300:]}")
                if side == "hand" and proc.returncode != 0:
                    raise SystemExit(f"hand-written child failed: {proc.stderr.strip()[-300:]}")
            if i == 0:
                continue  # the warm-up round
            ratios.append(took["robokit"] / took["hand"])
            for side in took:
                walls[side].append(took[side])
    print(f"{job} whole job (process wall time), robokit / hand-written: {_stats(ratios)}; "
          f"median robokit {statistics.median(walls['robokit']):.2f} s, "
          f"hand-written {statistics.median(walls['hand']):.2f} s", flush=True)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="seeds for the loop ratios (0, 1, ...)")
    parser.add_argument("--job-seeds", type=int, default=5, help="seeds for the whole-process runs (0, 1, ...)")
    parser.add_argument("--pairs", type=int, default=1,
                        help="interleaved robokit/hand-written pairs per seed; each side's fastest run is compared "
                             "(3 gives a steadier figure on a shared machine)")
    parser.add_argument("--jobs", nargs="+", choices=sorted(JOBS), default=sorted(JOBS, reverse=True))
    parser.add_argument("--set", type=_override, action="append", default=[], metavar="KEY=VALUE",
                        help="config override on robokit's side of the loop runs (repeatable), e.g. "
                             "sensors.scan.map_in_numpy=false; the whole-job runs use the config as it is")
    parser.add_argument("--callgrind", type=int, default=0, metavar="N",
                        help="instead of timing: count each side's loop instructions under valgrind's callgrind on "
                             "seeds 0..N-1 (load-independent; about a minute a seed)")
    parser.add_argument("--child", choices=sorted(JOBS), help=argparse.SUPPRESS)
    parser.add_argument("--side", choices=("hand", "robokit"), default="hand", help=argparse.SUPPRESS)
    parser.add_argument("--callgrind-child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--seed", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.pairs < 1 or args.seeds < 1:
        parser.error("--pairs and --seeds must be at least 1")
    OVERRIDES.update(args.set)
    if args.child:
        UNDER_CALLGRIND.extend([True] if args.callgrind_child else [])
        out = (robokit_run if args.side == "robokit" else hand_run)(args.child, args.seed)
        print(json.dumps({"ok": out["ok"], "sim": out["sim"], "result": out["result"]}, default=str))
        return
    if args.callgrind:
        for job in args.jobs:
            instruction_ratios(job, list(range(args.callgrind)))
        return
    if OVERRIDES:
        print(f"robokit's loop runs with: {', '.join(f'{k} = {v!r}' for k, v in OVERRIDES.items())}")
    print(f"load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f} "
          f"(1/5/15 min) on {os.cpu_count()} cores; python {sys.version.split()[0]}", flush=True)
    for job in args.jobs:
        loop_ratios(job, list(range(args.seeds)), args.pairs)
        if args.job_seeds:
            job_ratios(job, list(range(args.job_seeds)))
    print(f"load after: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}")


if __name__ == "__main__":
    main()
