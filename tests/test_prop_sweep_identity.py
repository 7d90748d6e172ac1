"""What a resumed sweep compares, over generated configs and identities.

docs/sweeps.md: resuming into a folder whose sweep had different inputs is refused with one line naming what changed
-- the config's text, the fixed overrides, the ``--plugin`` modules, any file the config refers to (a string in the
config, or in a ``--set`` / grid value, naming a file next to it; and the meshes each URDF names), robokit's,
pybullet's and each plugin's version -- and keys an older folder did not record are not compared. Here configs,
files, URDFs and identities are generated, and each answer is worked out plainly: which strings name a file, which
meshes a URDF names, which entries of two identities differ.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.sweep.identity import file_digests, referenced_files, what_changed

PROPS = settings(max_examples=40, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])
NAMES = ["robot.urdf", "arm.xacro", "policy.npz", "meshes/a.obj", "meshes/b.stl", "gone.urdf", "data/x.csv", ""]


@settings(PROPS, max_examples=20)
@given(st.lists(st.sampled_from(NAMES), max_size=5), st.lists(st.sampled_from(NAMES), max_size=3),
       st.lists(st.sampled_from(["meshes/a.obj", "meshes/b.stl", "meshes/missing.obj", "package://x/m.stl"]),
                max_size=3), st.booleans())
def test_every_file_the_config_names_is_found_with_the_meshes_of_its_urdfs(
        tmp_path_factory: pytest.TempPathFactory, in_config: list[str], in_values: list[str], meshes: list[str],
        broken_urdf: bool) -> None:
    base = tmp_path_factory.mktemp("cfg")
    for name in ("robot.urdf", "arm.xacro", "policy.npz", "meshes/a.obj", "meshes/b.stl", "data/x.csv"):
        (base / name).parent.mkdir(parents=True, exist_ok=True)
        (base / name).write_text(f"contents of {name}")
    urdf = "".join(f'<link name="l{i}"><visual><geometry><mesh filename="{m}"/></geometry></visual></link>'
                   for i, m in enumerate(meshes))
    (base / "robot.urdf").write_text("<robot" if broken_urdf else f'<robot name="r">{urdf}</robot>')
    raw = {"robots": {"r": {"urdf": in_config[0] if in_config else "plane.urdf", "n": 3}},
           "behaviour": {"files": in_config[1:], "flag": True, "note": "line one\nline two"}}
    named = {n for n in [*in_config, *in_values] if n and (base / n).is_file()}
    want = {(base / n).resolve() for n in named}
    for n in named:
        if n.endswith((".urdf", ".xacro")) and n == "robot.urdf" and not broken_urdf:
            want |= {(base / m).resolve() for m in meshes if "://" not in m and (base / m).is_file()}
    got = referenced_files(raw, base, in_values)
    assert got == sorted(want)
    digests = file_digests(raw, base, in_values)
    assert digests == {p.relative_to(base.resolve()).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
                       for p in sorted(want)}


digest = st.sampled_from(["a" * 64, "b" * 64, "c" * 64])
identities = st.fixed_dictionaries({}, optional={
    "config_sha256": digest, "fixed": st.dictionaries(st.sampled_from(["world.seed", "b.m"]), st.integers(0, 2),
                                                      max_size=2),
    "plugins": st.lists(st.sampled_from(["mine", "yours"]), max_size=2, unique=True),
    "files": st.dictionaries(st.sampled_from(["robot.urdf", "p.npz", "m/a.obj"]), digest, max_size=3),
    "versions": st.dictionaries(st.sampled_from(["robokit", "pybullet", "robokit-extra"]),
                                st.sampled_from(["0.1.0", "0.2.0", ""]), max_size=3)})


@settings(max_examples=60, deadline=None, derandomize=True)
@given(identities, identities)
def test_a_resume_names_every_input_that_changed_and_nothing_else(old: dict[str, Any], new: dict[str, Any]) -> None:
    changes = what_changed(old, new)
    labels = {"config_sha256": "the config file's text changed", "fixed": "the fixed overrides (--set) changed",
              "plugins": "the --plugin modules changed"}
    want = [labels[k] for k in labels if k in old and old[k] != new.get(k)]
    if "files" in old:
        now = new.get("files", {})
        for name in sorted(set(old["files"]) | set(now)):
            if name not in now:
                want.append(f"{name} is no longer referred to or is missing")
            elif name not in old["files"]:
                want.append(f"{name} is newly referred to")
            elif old["files"][name] != now[name]:
                want.append(f"{name} changed (sha256 {old['files'][name][:12]} -> {now[name][:12]})")
    if "versions" in old:
        now = new.get("versions", {})
        for name in sorted(set(old["versions"]) | set(now)):
            a, b = old["versions"].get(name), now.get(name)
            if a != b:
                want.append(f"{name} {a or '(absent)'} -> {b or '(absent)'}")
    assert changes == want
    assert what_changed(new, new) == [] and what_changed({}, new) == []  # the same inputs, or an older folder


def test_identity_digests_are_of_the_files_bytes(tmp_path: Path) -> None:
    (tmp_path / "big.npz").write_bytes(bytes(range(256)) * 9000)  # more than one read block
    assert file_digests({"p": "big.npz"}, tmp_path) == {"big.npz": hashlib.sha256(bytes(range(256)) * 9000)
                                                        .hexdigest()}
