"""Exports travel: a .mcap and a .rrd copied to another folder and read where pybullet and its data files cannot be
imported still draw every body, hold no path of the machine that made them, and put the run on sim time.

The oracle for the meshes is the URDF (which links have a visual) and the OBJ files themselves (their vertices'
bounding boxes, read here with a plain parse), not robokit's reader.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from robokit.cli import main
from robokit.record.format import find_run

SCENE = """
[world]
max_time = 1.0

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.2, 0.2, 0.2]
position = [0.6, 0, 0.3]
rgba = [0.9, 0.1, 0.1, 1]

[robots.kuka]
urdf = "kuka_iiwa/model.urdf"
position = [0, 0, 0]
fixed_base = true

[behaviour]
type = "record"
components = []
duration = 0.2
"""

BLOCKED = "import sys\nfor name in ('pybullet', 'pybullet_data', 'robokit'):\n    sys.modules[name] = None\n"
"""Prepended to the readers: the exporting machine's data files and robokit itself cannot be imported there."""

READ_MCAP = BLOCKED + """
import base64, json
import numpy as np
from mcap.reader import make_reader
out = {}
with open(sys.argv[1], 'rb') as f:
    for _, channel, message in make_reader(f).iter_messages(topics=['/scene']):
        for e in json.loads(message.data)['entities']:
            shapes = []
            for kind in ('cubes', 'spheres', 'cylinders'):
                shapes += [[kind, 0, None] for _ in e.get(kind, [])]
            for m in e.get('models', []):
                assert m['url'] == '' and m['media_type'] == 'model/stl', m['media_type']
                data = base64.b64decode(m['data'])
                n = int(np.frombuffer(data[80:84], '<u4')[0])
                rows = np.frombuffer(data[84:84 + 50 * n], dtype=[('n', '<f4', 3), ('v', '<f4', (3, 3)), ('a', '<u2')])
                v = rows['v'].reshape(-1, 3)
                shapes.append(['model', n, [v.min(0).tolist(), v.max(0).tolist()]])
            out[e['id']] = shapes
print(json.dumps(out))
"""

READ_RRD = BLOCKED + """
import json
import rerun.chunk
blobs, timelines, transforms = {}, set(), 0
for chunk in rerun.chunk.RrdReader(sys.argv[1]).store().stream():
    batch = chunk.to_record_batch()
    timelines |= set(chunk.timeline_names)
    if 'Asset3D:blob' in batch.schema.names:
        for blob in batch.column('Asset3D:blob').to_pylist():
            blobs[chunk.entity_path] = len(blob[0]) if blob else 0
    for name in batch.schema.names:
        if name.startswith(('Boxes3D:half_sizes', 'Ellipsoids3D:half_sizes', 'Cylinders3D:lengths')):
            blobs[chunk.entity_path] = -1
    if 'Transform3D:translation' in batch.schema.names:
        transforms += chunk.num_rows
print(json.dumps({'shapes': blobs, 'timelines': sorted(timelines), 'transforms': transforms}))
"""


def _obj_bounds(path: Path) -> tuple[list[float], list[float]]:
    """Bounding box of an OBJ's vertices (a plain parse of its ``v`` lines)."""
    vs = np.array([[float(x) for x in line.split()[1:4]] for line in path.read_text().splitlines()
                   if line.startswith("v ")])
    return vs.min(0).tolist(), vs.max(0).tolist()


def _urdf_visual_meshes(urdf: Path) -> dict[str, Path]:
    """Each link with a mesh visual: the mesh file (the oracle's view of the URDF)."""
    out = {}
    for link in ET.parse(urdf).getroot().iter("link"):
        mesh = link.find("visual/geometry/mesh")
        if mesh is not None:
            out[str(link.get("name"))] = urdf.parent / str(mesh.get("filename"))
    return out


@pytest.fixture(scope="module")
def exports(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(the folder that made the run and its exports, a copy of the exports elsewhere)."""
    made = tmp_path_factory.mktemp("made")
    (made / "scene.toml").write_text(SCENE)
    cwd = os.getcwd()
    os.chdir(made)
    try:
        assert main(["run", "scene.toml", "--quiet"]) == 0
        run = find_run("last").folder
        assert main(["export", str(run), "--rerun", "out/run.rrd", "--mcap", "out/run.mcap"]) == 0
    finally:
        os.chdir(cwd)
    elsewhere = tmp_path_factory.mktemp("elsewhere")
    for name in ("run.rrd", "run.mcap"):
        shutil.copy(made / "out" / name, elsewhere / name)
    return made, elsewhere


def _read(script: str, path: Path) -> dict:
    done = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True, text=True, timeout=120,
                          cwd=path.parent)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout)


def test_no_export_holds_a_path_of_the_machine_that_made_it(exports: tuple[Path, Path]) -> None:
    import pybullet_data

    made, elsewhere = exports
    machine = {str(made), sys.prefix, pybullet_data.getDataPath(), str(Path.home()), "file://"}
    for name in ("run.rrd", "run.mcap"):
        data = (elsewhere / name).read_bytes()
        assert [m for m in machine if m.encode() in data] == [], name
    assert [p.name for p in (made / "out").iterdir()] and not list((made / "out").glob(".*part*"))


def test_the_mcap_draws_every_body_from_its_own_bytes(exports: tuple[Path, Path]) -> None:
    import pybullet_data

    _, elsewhere = exports
    scene = _read(READ_MCAP, elsewhere / "run.mcap")
    kuka = _urdf_visual_meshes(Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf")
    assert set(scene) == {f"kuka/{link}" for link in kuka} | {"plane/planeLink", "box/link0"}, sorted(scene)
    assert all(scene[frame] for frame in scene)  # every body is drawn: no entity without a shape
    assert scene["box/link0"] == [["cubes", 0, None]]
    for link, mesh in kuka.items():
        [[kind, triangles, bounds]] = scene[f"kuka/{link}"]
        assert kind == "model" and triangles > 100
        low, high = _obj_bounds(mesh)
        assert np.allclose(bounds[0], low, atol=1e-5) and np.allclose(bounds[1], high, atol=1e-5), link
    [[kind, triangles, _]] = scene["plane/planeLink"]
    assert kind == "model" and triangles >= 2


def test_the_rrd_draws_every_body_on_the_sim_timeline_alone(exports: tuple[Path, Path]) -> None:
    import pybullet_data

    made, elsewhere = exports
    got = _read(READ_RRD, elsewhere / "run.rrd")
    kuka = _urdf_visual_meshes(Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf")
    frames = {"/".join(p.split("/")[2:4]) for p in got["shapes"]}
    assert frames == {f"kuka/{link}" for link in kuka} | {"plane/planeLink", "box/link0"}
    assert all(size != 0 for size in got["shapes"].values())  # every mesh shape carries its bytes
    assert got["timelines"] == ["sim"]  # no wall-clock log_time: the viewer opens on sim time
    samples = len(np.load(find_run("last", made / "results").folder / "poses.npz")["t"])
    assert got["transforms"] == samples * len(frames)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["rerun", "mcap"])
def test_an_export_that_cannot_be_finished_leaves_nothing_and_exits_6(exports: tuple[Path, Path], kind: str) -> None:
    made, _ = exports
    out = made / "limited" / f"run.{'rrd' if kind == 'rerun' else 'mcap'}"
    robokit = [sys.executable, "-c", "import sys; from robokit.cli import main; sys.exit(main())"]
    done = subprocess.run(["prlimit", "--fsize=20000", *robokit, "export", "last", f"--{kind}", str(out)],
                          cwd=made, capture_output=True, text=True, timeout=120)
    assert done.returncode == 6, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"robokit: warning: {out}: not written: "), lines
    assert list(out.parent.iterdir()) == []  # neither the name asked for nor a temporary file
