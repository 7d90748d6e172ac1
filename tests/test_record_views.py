"""Looking at a run afterwards: video, plots, camera frames, the run page in a real headless Chromium, the GUI's
display check and pybullet's C output kept off stdout."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robokit.cli import main
from robokit.record.format import find_run

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = ROOT / "configs"

SCENE = """
[world]
max_time = 2.0

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.2, 0.2, 0.2]
position = [0.3, 0, 0.6]
rgba = [0.9, 0.1, 0.1, 1]

[robots.kuka]
urdf = "kuka_iiwa/model.urdf"
position = [0, 0, 0]
fixed_base = true

[sensors.cam]
type = "camera"
width = 64
height = 48
eye = [1.5, 0, 0.8]
target = [0, 0, 0.4]

[actuators.joints]
type = "joint_control"
body = "kuka"
mode = "position"
[actuators.joints.sine.lbr_iiwa_joint_2]
amplitude = 0.8
frequency_hz = 1.0

[behaviour]
type = "record"
components = ["cam"]
rate_hz = 4
duration = 1.0
"""


def robokit(*args: str, cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robokit.cli", *args], capture_output=True, text=True,
                          timeout=600, cwd=cwd, env=env)


@pytest.fixture
def scene(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    return path


def video_meta(path: Path) -> tuple[dict, list[np.ndarray]]:
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    w, h = meta["size"]
    frames = [np.frombuffer(f, np.uint8).reshape(h, w, 3) for f in reader]
    return meta, frames


@pytest.mark.slow
def test_video_has_a_frame_per_pose_sample_at_the_asked_size(scene: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["run", str(scene), "--quiet"]) == 0
    assert main(["video", "last", "-o", "clip.mp4", "--size", "160x120"]) == 0
    assert "clip.mp4: 31 frames, 160x120, 30 fps, H.264" in capsys.readouterr().out
    meta, frames = video_meta(Path("clip.mp4"))
    assert meta["codec"].startswith("h264") and "yuv420p" in meta["pix_fmt"] and meta["fps"] == 30
    assert len(frames) == 31 and frames[0].shape == (120, 160, 3)  # 1 s at 30 Hz, both ends
    assert frames[0].std() > 10  # a scene, not a blank frame
    assert not np.array_equal(frames[5], frames[25])  # the arm moves, the box falls
    assert main(["video", "last", "-o", "slow.mp4", "--size", "160x120", "--fps", "5"]) == 0
    assert len(video_meta(Path("slow.mp4"))[1]) == 6
    assert main(["video", "last", "--size", "161x120"]) == 2
    assert "--size: width and height must be even" in capsys.readouterr().err
    assert main(["video", "last", "--view", "nowhere"]) == 2
    assert "unknown view 'nowhere'; choose one of iso, front" in capsys.readouterr().err


def test_camera_frames_are_saved_as_rgb_depth_and_segmentation_pngs(scene: Path) -> None:
    import cv2

    assert main(["run", str(scene), "--quiet", "--save-frames"]) == 0
    frames = sorted((find_run("last").folder / "frames").glob("*.png"))
    stems = sorted({p.name.rsplit("_", 1)[0] for p in frames})
    assert stems == [f"cam_{tick:06d}" for tick in range(0, 241, 60)]  # read 4 times a second, and at the end
    assert len(frames) == 3 * len(stems)
    rgb = cv2.imread(str(frames[2]))  # cam_000000_rgb.png
    seg = cv2.imread(str(frames[1]))
    depth = cv2.imread(str(frames[0]))
    assert rgb.shape == seg.shape == depth.shape == (48, 64, 3)
    assert len(np.unique(seg.reshape(-1, 3), axis=0)) >= 3  # plane, box, robot (+ background)
    assert depth.std() > 5


def test_plots_for_joint_control_and_the_state_timeline(scene: Path) -> None:
    assert main(["run", str(scene), "--quiet"]) == 0
    rec = find_run("last")
    assert main(["plot", "last"]) == 0
    made = sorted(p.name for p in (rec.folder / "plots").iterdir())
    assert made == ["joints.png"]  # a record behaviour has no machine; a robot: no heights plot
    assert (rec.folder / "plots" / "joints.png").stat().st_size > 10_000
    assert main(["plot", "last", "--format", "svg", "-o", "svgs"]) == 0
    assert Path("svgs/joints.svg").read_text().count("<path") > 7


def test_plots_of_the_drop_test_show_heights(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(CONFIGS / "drop_test.toml"), "--quiet", "--max-time", "1.5"]) in (0, 1)
    assert main(["plot", "last"]) == 0
    heights = find_run("last").folder / "plots" / "heights.png"
    assert heights.stat().st_size > 20_000


@pytest.mark.slow
def test_mobile_plots_map_and_lidar(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(CONFIGS / "go_to_goal.toml"), "--quiet"]) == 0
    assert main(["plot", "last", "--scan-at", "2.0"]) == 0
    folder = find_run("last").folder / "plots"
    assert sorted(p.name for p in folder.iterdir()) == ["lidar.png", "map.png", "states.png"]
    assert all(p.stat().st_size > 15_000 for p in folder.iterdir())


def test_gui_without_a_display_is_one_line_and_exit_2(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    proc = robokit("run", str(CONFIGS / "drop_test.toml"), "--gui", cwd=tmp_path, env=env)
    assert proc.returncode == 2 and proc.stdout == ""
    (line,) = proc.stderr.strip().splitlines()
    assert line.startswith("robokit: error: no display") and "xvfb-run -a robokit run" in line
    assert not (tmp_path / "results").exists()


def test_inspect_json_stays_json_when_pybullet_warns(tmp_path: Path) -> None:
    proc = robokit("inspect", "humanoid/humanoid.urdf", "--json", cwd=tmp_path)
    assert proc.returncode == 0
    table = json.loads(proc.stdout)  # b3Warning lines did not land on stdout
    assert table["urdf"] == "humanoid/humanoid.urdf" and len(table["joints"]) > 10
    notes = [line for line in proc.stderr.splitlines() if "pybullet printed" in line]
    assert len(notes) == 1 and "no axis element for Joint" in notes[0]  # summarised once, on stderr, by its text
    assert ".cpp" not in notes[0]


def test_quiet_prints_nothing_and_json_is_json(scene: Path) -> None:
    proc = robokit("run", str(scene), "--quiet", cwd=scene.parent)
    assert proc.returncode == 0 and proc.stdout == "" and proc.stderr == ""
    proc = robokit("run", str(scene), "--json", cwd=scene.parent)
    assert json.loads(proc.stdout)["outcome"] == "succeeded"


# ----------------------------------------------------------------- the main job, end to end (slow)
@pytest.fixture(scope="module")
def sort_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("sort")
    proc = robokit("run", str(CONFIGS / "sort_robot.toml"), cwd=folder)
    assert proc.returncode == 0, proc.stderr
    proc = robokit("video", "last", "-o", "sort.mp4", "--size", "320x240", "--fps", "3", cwd=folder)
    assert proc.returncode == 0, proc.stderr
    return folder


@pytest.mark.slow
def test_the_sort_video_ends_with_red_cubes_in_the_red_bin(sort_run: Path) -> None:
    from robokit.record.scene import choose_view, rebuild
    from robokit.record.video import Renderer

    meta, frames = video_meta(sort_run / "sort.mp4")
    rec = find_run("last", sort_run / "results")
    assert len(frames) == int(rec.sim_time * 3) + 1 and meta["size"] == (320, 240)
    last = frames[-1].astype(int)
    red = (last[:, :, 0] > 150) & (last[:, :, 1] < 90) & (last[:, :, 2] < 90)
    with rebuild(rec) as scene:
        scene.set_frame(len(rec.poses["t"]) - 1)
        renderer = Renderer(scene, choose_view(scene, None, 320 / 240), (320, 240))

        def region(body: str) -> np.ndarray:
            lo, hi = scene.world.body_aabb(body)
            corners = [renderer.project((x, y, z)) for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                       for z in (lo[2], hi[2])]
            cols, rows = zip(*corners, strict=True)
            return red[int(max(0, min(rows))):int(max(rows)) + 1, int(max(0, min(cols))):int(max(cols)) + 1]

        in_red_bin, in_blue_bin = int(region("red_bin").sum()), int(region("blue_bin").sum())
    assert in_red_bin > 30, "the red cubes are drawn inside the red bin's part of the picture"
    assert in_red_bin > 5 * in_blue_bin


@pytest.mark.slow
def test_the_run_page_in_headless_chromium(sort_run: Path) -> None:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    assert main(["plot", "last", "--dir", str(sort_run / "results")]) == 0
    page = sort_run / "sort.html"
    assert main(["view", "last", "--dir", str(sort_run / "results"), "-o", str(page)]) == 0
    html = page.read_text()
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", html)  # self-contained: nothing to fetch
    opts = webdriver.ChromeOptions()
    opts.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--window-size=1200,2400"):
        opts.add_argument(arg)
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver") or "/usr/bin/chromedriver"), options=opts)
    try:
        driver.get(page.as_uri())
        video = driver.execute_async_script(
            "const done = arguments[0]; const v = document.getElementById('run-video');"
            "const report = () => done({ready: v.readyState, duration: v.duration, w: v.videoWidth});"
            "if (v.readyState >= 1) report(); else { v.addEventListener('loadedmetadata', report);"
            " v.addEventListener('error', () => done({error: String(v.error && v.error.code)})); }")
        assert video.get("ready", 0) >= 1 and video["duration"] > 2 and video["w"] == 320, video
        images = driver.execute_script(
            "return Array.from(document.images).map(i => [i.alt, i.complete && i.naturalWidth])")
        assert sorted(alt for alt, _ in images) == ["states"] and all(w > 100 for _, w in images), images
        assert driver.execute_script("return document.querySelectorAll('svg.fsm g.state.visited').length") >= 10
        # Hangul, not tofu: two different Korean words drawn in the page's font give different pictures
        differ = driver.execute_script(
            "const font = getComputedStyle(document.querySelector('h2 .ko')).fontFamily;"
            "const draw = t => { const c = document.createElement('canvas'); c.width = 120; c.height = 40;"
            " const g = c.getContext('2d'); g.font = '24px ' + font; g.fillText(t, 4, 30); return c.toDataURL(); };"
            "return [draw('상태'), draw('결과'), draw('□□')];")
        assert differ[0] != differ[1] and differ[0] != differ[2], "Korean text renders as boxes"
        driver.set_window_size(1200, 1400)
        driver.save_screenshot(str(sort_run / "page.png"))
    finally:
        driver.quit()
    import cv2

    shot = cv2.imread(str(sort_run / "page.png"))
    assert shot is not None and shot.shape[1] >= 1000 and shot.std() > 20  # a page, not a blank window
