"""``robokit robot new NAME --kind KIND``: a parametric xacro robot and a config that drives it.

The templates live in ``robokit/data/robots/scaffold/``: ``diffdrive`` (diff_drive + go_to_goal around lesson 07's
boxes), ``arm`` (ik_arm + suction + pick_place on lesson 06's cube) and ``gripper-arm`` (the same arm with two
fingers, the gripper actuator). Both engines run the configs unchanged.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from robokit.errors import UserError

SCAFFOLD_DIR = Path(__file__).resolve().parent.parent / "data" / "robots" / "scaffold"


@dataclass(frozen=True)
class Kind:
    """A scaffold: its xacro template, config template and the xacro ``tool`` default (arms only)."""

    xacro: str
    config: str
    tool: str = ""


KINDS = {
    "diffdrive": Kind("diffdrive.urdf.xacro", "diffdrive.toml"),
    "arm": Kind("arm.urdf.xacro", "arm.toml", tool="suction"),
    "gripper-arm": Kind("arm.urdf.xacro", "gripper-arm.toml", tool="gripper"),
}

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,63}$")


def new_robot(name: str, kind: str, folder: Path | None = None, *, force: bool = False) -> tuple[Path, Path]:
    """Write ``NAME.urdf.xacro`` and ``NAME.toml`` into ``folder`` (default ``./NAME``); returns both paths.

    Raises:
        UserError: A name that is not an identifier, an unknown kind, or files already there (without ``force``).
    """
    if not _NAME.match(name):
        raise UserError(f"robot name {name!r}: use letters, digits and '_', starting with a letter")
    if kind not in KINDS:
        raise UserError(f"unknown kind {kind!r}; kinds: {', '.join(KINDS)}")
    spec = KINDS[kind]
    folder = Path(name) if folder is None else folder
    xacro_path, config_path = folder / f"{name}.urdf.xacro", folder / f"{name}.toml"
    if not force:
        for path in (xacro_path, config_path):
            if path.exists():
                raise UserError(f"{path} already exists (--force writes over it)")
    texts = {}
    for path, template in ((xacro_path, spec.xacro), (config_path, spec.config)):
        text = (SCAFFOLD_DIR / template).read_text(encoding="utf-8")
        texts[path] = text.replace("ROBOT_NAME", name).replace("TOOL_KIND", spec.tool).replace("KIND_NAME", kind)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for path, text in texts.items():
            tmp = path.with_name(f".{path.name}.tmp")
            tmp.write_text(text, encoding="utf-8")
            tmp.replace(path)
    except OSError as exc:
        raise UserError(f"{folder}: cannot write the robot: {exc.strerror or exc}") from None
    return xacro_path, config_path
