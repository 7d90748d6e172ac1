"""``robokit robot show``: a robot drawn from the front, the side and above at its zero pose, each moving joint's
frame (x red, y green, z blue) and axis (a yellow arrow) drawn and labelled with its name.

Rendering is PyBullet's TinyRenderer in a DIRECT client of its own; the frames and labels are drawn on the
images with OpenCV, projected with the same view and projection matrices the renderer used.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from robokit.errors import UserError
from robokit.robot.model import Robot

VIEWS = (("front", (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)), ("side", (0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
         ("top", (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)))
"""Name, direction from the robot to the eye, and the image's up direction (world frame)."""
FOV_DEG = 30.0


def _look(center: np.ndarray, eye_dir: tuple[float, float, float], up: tuple[float, float, float],
          distance: float) -> np.ndarray:
    """A view matrix (4x4, OpenGL convention) looking at ``center`` from ``distance`` along ``eye_dir``."""
    eye = center + np.asarray(eye_dir) * distance
    f = center - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def _projection(aspect: float, near: float, far: float) -> np.ndarray:
    f = 1.0 / np.tan(np.radians(FOV_DEG) / 2)
    return np.array([[f / aspect, 0, 0, 0], [0, f, 0, 0],
                      [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)], [0, 0, -1, 0]])


def _pixel(p: np.ndarray, view: np.ndarray, proj: np.ndarray, w: int, h: int) -> tuple[int, int]:
    clip = proj @ view @ np.append(p, 1.0)
    ndc = clip[:3] / clip[3]
    return int(round((ndc[0] + 1) / 2 * w)), int(round((1 - ndc[1]) / 2 * h))


def _frames(client: Any, body: int) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
    """Each moving joint: name, position (world), rotation of its frame (3x3), axis (world, unit)."""
    out = []
    for i in range(client.getNumJoints(body)):
        info = client.getJointInfo(body, i)
        if info[2] == client.JOINT_FIXED:
            continue
        state = client.getLinkState(body, i, computeForwardKinematics=True)
        pos, orn = np.array(state[4]), state[5]
        rot = np.array(client.getMatrixFromQuaternion(orn)).reshape(3, 3)
        axis = rot @ np.array(info[13])
        n = np.linalg.norm(axis)
        out.append((info[1].decode(), pos, rot, axis / n if n > 0 else axis))
    return out


def _bounds(client: Any, body: int) -> tuple[np.ndarray, np.ndarray]:
    boxes = [client.getAABB(body, i) for i in range(-1, client.getNumJoints(body))]
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    return lo, hi


def _render_view(client: Any, body: int, name: str, eye_dir: Any, up: Any, height: int) -> np.ndarray:
    import cv2

    lo, hi = _bounds(client, body)
    center, size = (lo + hi) / 2, float(max(np.max(hi - lo), 0.05))
    width = int(height * 4 / 3)
    distance = size / np.tan(np.radians(FOV_DEG) / 2) * 0.75
    view = _look(center, eye_dir, up, distance)
    proj = _projection(width / height, distance / 10, distance * 10)
    img = client.getCameraImage(width, height, viewMatrix=view.T.flatten().tolist(),
                                projectionMatrix=proj.T.flatten().tolist(), renderer=client.ER_TINY_RENDERER,
                                lightDirection=[1, -1, 2])[2]
    rgb = np.ascontiguousarray(np.reshape(img, (height, width, 4))[:, :, :3][:, :, ::-1])  # BGR for OpenCV
    scale = size * 0.18
    for joint, pos, rot, axis in _frames(client, body):
        origin = _pixel(pos, view, proj, width, height)
        for k, colour in enumerate(((0, 0, 220), (0, 170, 0), (220, 60, 0))):  # x red, y green, z blue (BGR)
            cv2.line(rgb, origin, _pixel(pos + rot[:, k] * scale * 0.5, view, proj, width, height), colour, 1,
                     cv2.LINE_AA)
        tip = _pixel(pos + axis * scale, view, proj, width, height)
        cv2.arrowedLine(rgb, origin, tip, (0, 200, 255), 2, cv2.LINE_AA, tipLength=0.25)
        for colour, thickness in (((255, 255, 255), 3), ((0, 0, 0), 1)):  # dark text on a light outline
            cv2.putText(rgb, joint, (origin[0] + 4, origin[1] - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.38, colour,
                        thickness, cv2.LINE_AA)
    cv2.putText(rgb, name, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 1, cv2.LINE_AA)
    return rgb


def draw_robot(robot: Robot, output: str | os.PathLike[str], *, height: int = 360) -> Path:
    """Render the three views side by side into ``output`` (PNG, written atomically); returns its path.

    Raises:
        UserError: PyBullet cannot load the robot, or the file cannot be written.
    """
    import cv2
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from robokit.process.quiet import quiet_stdout

    with quiet_stdout():
        client = BulletClient(connection_mode=pybullet.DIRECT)
        try:
            try:
                body = client.loadURDF(str(robot.path), useFixedBase=True)
            except pybullet.error:
                body = -1
            views = [] if body < 0 else [_render_view(client, body, n, e, u, height) for n, e, u in VIEWS]
        finally:
            client.disconnect()
    if body < 0:
        raise UserError(f"{robot.source or robot.path}: PyBullet cannot load it (robokit robot check says why)")
    sheet = np.concatenate(views, axis=1)
    cv2.putText(sheet, f"{robot.name}: joint frames x red, y green, z blue; joint axis yellow",
                (8, sheet.shape[0] - 10), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (60, 60, 60), 1, cv2.LINE_AA)
    out = Path(output)
    tmp = out.with_name(f".{out.name}.tmp.png")
    if not cv2.imwrite(str(tmp), sheet):
        raise UserError(f"{out}: cannot write the picture")
    os.replace(tmp, out)
    return out
