"""What the 3D replay and the exports draw: each link frame's world pose per sample (checked against pybullet's own
forward kinematics of the logged joints), the visual shapes, and the page's payload."""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np
import pytest

from robokit.cli import main
from robokit.record.format import find_run
from robokit.record.replay import payload, read_obj, replay_of

SCENE = """
[world]
max_time = 2.0

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.2, 0.1, 0.3]
position = [0.6, 0, 0.6]
rgba = [0.9, 0.1, 0.1, 1]

[robots.kuka]
urdf = "kuka_iiwa/model.urdf"
position = [0, 0, 0]
fixed_base = true

[actuators.joints]
type = "joint_control"
body = "kuka"
mode = "position"
[actuators.joints.sine.lbr_iiwa_joint_2]
amplitude = 0.8
frequency_hz = 1.0

[behaviour]
type = "record"
components = []
duration = 0.5
"""


@pytest.fixture(scope="module")
def record(tmp_path_factory: pytest.TempPathFactory) -> Path:
    import os

    folder = tmp_path_factory.mktemp("model")
    (folder / "scene.toml").write_text(SCENE)
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        assert main(["run", "scene.toml", "--quiet"]) == 0
    finally:
        os.chdir(cwd)
    return find_run("last", folder / "results").folder


def test_link_frames_match_pybullets_forward_kinematics_of_the_logged_joints(record: Path) -> None:
    import pybullet as p
    import pybullet_data

    rec = find_run(str(record))
    replay = replay_of(rec)
    poses = np.load(record / "poses.npz")
    header = json.loads((record / "trace.jsonl").read_text().splitlines()[0])
    assert len(replay.t) == len(poses["t"]) and np.allclose(replay.t, poses["t"])
    client = p.connect(p.DIRECT)
    try:
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=client)
        kuka = p.loadURDF("kuka_iiwa/model.urdf", useFixedBase=True, physicsClientId=client)
        joints = {p.getJointInfo(kuka, j, physicsClientId=client)[1].decode(): j
                  for j in range(p.getNumJoints(kuka, physicsClientId=client))}
        links = {p.getJointInfo(kuka, j, physicsClientId=client)[12].decode(): j for j in joints.values()}
        for sample in (0, len(poses["t"]) // 2, len(poses["t"]) - 1):
            for name, q in zip(header["bodies"]["kuka"]["joints"], poses["joints/kuka"][sample], strict=True):
                p.resetJointState(kuka, joints[name], float(q), physicsClientId=client)
            for k, link in enumerate(replay.links):
                if link.body == "kuka" and link.index >= 0:
                    state = p.getLinkState(kuka, links[link.link], computeForwardKinematics=True,
                                           physicsClientId=client)
                    assert np.allclose(replay.poses[sample, k, :3], state[4], atol=1e-5), link.path
                    assert abs(float(np.dot(replay.poses[sample, k, 3:], state[5]))) == pytest.approx(1, abs=1e-5)
    finally:
        p.disconnect(client)
    box = next(k for k, link in enumerate(replay.links) if link.body == "box")
    assert np.allclose(replay.poses[:, box, :3], poses["base/box"][:, :3], atol=1e-5)  # a box's frame is its centre
    shape = next(s for s in replay.shapes if s.frame == box)
    assert shape.kind == "box" and np.allclose(shape.size, (0.2, 0.1, 0.3)) and np.allclose(shape.rgba,
                                                                                          (0.9, 0.1, 0.1, 1))


def test_the_page_payload_carries_meshes_and_poses_as_arrays(record: Path, tmp_path: Path) -> None:
    rec = find_run(str(record))
    data = payload(rec)
    n, links = len(np.load(record / "poses.npz")["t"]), len(data["links"])
    poses = np.frombuffer(base64.b64decode(data["poses"]), np.float32)
    assert poses.size == n * links * 7
    assert any(s["kind"] == "mesh" and "mesh" in s for s in data["shapes"])  # the kuka's OBJ links
    mesh = max(data["meshes"], key=lambda m: len(m["vertices"]))  # the plane's is 4 corners; a kuka link's more
    vertices = np.frombuffer(base64.b64decode(mesh["vertices"]), np.float32).reshape(-1, 3)
    triangles = np.frombuffer(base64.b64decode(mesh["triangles"]), np.uint32).reshape(-1, 3)
    assert len(vertices) > 10 and triangles.max() < len(vertices)
    obj = tmp_path / "quad.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4 -2 -1\n")
    got = read_obj(obj)
    assert got is not None
    assert got[1].tolist() == [[0, 1, 2], [0, 2, 3], [0, 2, 3]]  # a quad fanned into two; negative indices


def test_a_textured_mesh_is_drawn_in_its_textures_mean_colour(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import cv2
    import pybullet_data

    (tmp_path / "table.toml").write_text('[world]\nmax_time = 0.05\n\n[bodies.table]\nurdf = "table/table.urdf"\n'
                                         'position = [0, 0, 0]\nfixed_base = true\n\n[bodies.box]\nshape = "box"\n'
                                         'size = [0.1, 0.1, 0.1]\nposition = [0, 0, 1]\nrgba = [0.1, 0.8, 0.2, 1]\n')
    monkeypatch.chdir(tmp_path)
    assert main(["run", "table.toml", "--quiet"]) == 0
    replay = replay_of(find_run("last", tmp_path / "results"))
    texture = cv2.imread(str(Path(pybullet_data.getDataPath()) / "table" / "table.png"))
    assert texture is not None
    mean_rgb = texture.reshape(-1, 3).mean(axis=0)[::-1] / 255  # OpenCV reads BGR
    table = [s for s in replay.shapes if replay.links[s.frame].body == "table"]
    assert table and all(np.allclose(s.rgba[:3], mean_rgb, atol=1e-6) for s in table)  # the URDF says white
    assert not np.allclose(mean_rgb, 1.0, atol=0.05)  # a texture that is not white: the test can fail
    box = [s for s in replay.shapes if replay.links[s.frame].body == "box"]
    assert len(box) == 1 and np.allclose(box[0].rgba, (0.1, 0.8, 0.2, 1.0), atol=1e-6)  # a plain colour is kept
