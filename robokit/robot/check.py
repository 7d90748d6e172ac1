"""``robokit robot check``: what is wrong with a robot description, one line per problem, each with its fix.

Static checks read the file (:mod:`robokit.robot.model`): names, the link tree, masses, inertias, joint axes,
limits, effort and velocity, mesh files. When those pass, physical checks load the robot in a PyBullet DIRECT
client of their own (:mod:`robokit.robot.physical`): the inertia's scale against the link's size, collision shapes
that overlap at the zero pose, and whether a mobile base stands on its wheels.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from robokit.errors import ConfigError
from robokit.robot.expand import expand_xacro, is_xacro
from robokit.robot.model import Joint, Link, Robot, read_robot
from robokit.robot.problem import Problem, is_mobile

CHECKS = ("names", "tree", "mass", "inertia", "inertia-scale", "axis", "limits", "effort", "mesh", "overlap",
          "wheels", "stability")
"""Every check, in the order they run."""


def load(path: str | Path, xacro_args: Mapping[str, object] | None = None) -> Robot:
    """Read a URDF, or a xacro file expanded with ``xacro_args``.

    Raises:
        UserError: The file cannot be read or expanded (one line).
    """
    src = Path(path)
    if is_xacro(src):
        return read_robot(expand_xacro(src, xacro_args), source=src)
    return read_robot(src, source=src)


def check_robot(robot: Robot, *, fixed_base: bool | None = None, physical: bool = True) -> list[Problem]:
    """Every problem of ``robot``. ``fixed_base``: how it is used (None: a robot with wheels is a mobile base).

    The physical checks run only when the static ones found nothing that stops the robot loading or standing.
    """
    problems = static_problems(robot, fixed_base=fixed_base)
    blocking = {"names", "tree", "mass", "inertia", "axis", "limits", "mesh"}
    if physical and not any(p.check in blocking for p in problems):
        from robokit.robot.physical import physical_problems

        problems += physical_problems(robot, fixed_base=fixed_base)
    if robot.source is not None and is_xacro(robot.source):  # line numbers of the expanded file mean nothing
        problems = [Problem(p.check, p.where, p.message, p.fix, warning=p.warning) for p in problems]
    return problems


def static_problems(robot: Robot, *, fixed_base: bool | None = None) -> list[Problem]:
    """The checks that need only the file."""
    out = _names(robot) + _tree(robot)
    mobile = is_mobile(robot, fixed_base)
    roots = robot.roots()
    for link in robot.links:
        out += _mass(link, is_root=bool(roots) and link.name == roots[0], mobile=mobile, robot=robot)
        out += _inertia(link)
    for joint in robot.joints:
        out += _axis(joint) + _limits(joint) + _effort(joint)
    out += _meshes(robot)
    return out


def _names(robot: Robot) -> list[Problem]:
    out = []
    for kind, items in (("link", robot.links), ("joint", robot.joints)):
        seen: dict[str, int] = {}
        for item in items:
            if not item.name:
                out.append(Problem("names", f"a {kind} at line {item.line}", "has no name",
                                   f'give it one: <{kind} name="...">', item.line))
            elif item.name in seen:
                out.append(Problem("names", f"{kind} {item.name!r}", f"the name is used twice (first at line "
                                   f"{seen[item.name]})", f"rename one of them: every {kind} needs its own name",
                                   item.line))
            else:
                seen[item.name] = item.line
    return out


def _tree(robot: Robot) -> list[Problem]:
    names = {lk.name for lk in robot.links}
    out = []
    parent_of: dict[str, str] = {}
    for j in robot.joints:
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in names:
                out.append(Problem("tree", f"joint {j.name!r}", f"its {role} link {link!r} is not defined",
                                   f'add <link name="{link}"> or name an existing link', j.line))
        if j.child in parent_of:
            out.append(Problem("tree", f"joint {j.name!r}", f"link {j.child!r} is already the child of joint "
                               f"{parent_of[j.child]!r}", "a link has one parent joint: attach it once", j.line))
        parent_of.setdefault(j.child, j.name)
    roots = robot.roots()
    if not roots and robot.links:
        out.append(Problem("tree", "the joints", "form a loop: every link is some joint's child",
                           "one link (the base) must be no joint's child", 0))
    for extra in roots[1:]:
        found = robot.link(extra)
        out.append(Problem("tree", f"link {extra!r}", f"is connected to nothing: {roots[0]!r} is the root, and no "
                           f"joint leads from it to {extra!r}",
                           f"add a joint with <child link=\"{extra}\"/> (fixed if it does not move) or remove the "
                           f"link", found.line if found else 0))
    return out or _cycles(robot, roots)


def _cycles(robot: Robot, roots: list[str]) -> list[Problem]:
    """Links no root reaches although they have a parent: they hang in a loop."""
    reached, todo = set(roots), list(roots)
    while todo:
        for j in robot.children(todo.pop()):
            if j.child not in reached:
                reached.add(j.child)
                todo.append(j.child)
    loop = [lk for lk in robot.links if lk.name not in reached]
    if not loop or not roots:
        return []
    return [Problem("tree", f"link {loop[0].name!r}", f"cannot be reached from the root {roots[0]!r}: the joints "
                    f"through {', '.join(repr(lk.name) for lk in loop)} form a loop",
                    "break the loop: each link has one parent, back towards the root", loop[0].line)]


def _mass(link: Link, *, is_root: bool, mobile: bool, robot: Robot) -> list[Problem]:
    where = f"link {link.name!r}"
    if link.mass is None:
        return []
    if link.mass < 0:
        return [Problem("mass", where, f"mass {link.mass:g} kg is negative", _mass_fix(link), link.line)]
    if link.mass == 0:
        driven = any(j.child == link.name and j.movable for j in robot.joints)
        if is_root and mobile:
            return [Problem("mass", where, "mass is 0 kg: a base of mass 0 is pinned in place by the engine",
                            _mass_fix(link), link.line)]
        if not is_root and driven and link.collisions:
            return [Problem("mass", where, "mass is 0 kg: a moving link of mass 0 makes the joint's dynamics "
                            "singular", _mass_fix(link), link.line)]
    return []


def _mass_fix(link: Link) -> str:
    size = _size(link)
    if size is None:
        return "give it a positive mass in kg"
    volume = size[0] * size[1] * size[2]
    return (f"give it a positive mass in kg (a solid {size[0]:.2g} x {size[1]:.2g} x {size[2]:.2g} m of plastic "
            f"weighs about {volume * 1200:.2g} kg)")


def _size(link: Link) -> tuple[float, float, float] | None:
    """Edge lengths (m) of the link's first primitive collision shape, or None."""
    for s in link.collisions:
        if s.kind == "box":
            return (s.size[0], s.size[1], s.size[2])
        if s.kind in ("cylinder", "capsule"):
            return (2 * s.size[0], 2 * s.size[0], s.size[1])
        if s.kind == "sphere":
            return (2 * s.size[0],) * 3
    return None


def principal_moments(inertia: tuple[float, float, float, float, float, float]) -> np.ndarray:
    """Eigenvalues (kg·m², ascending) of the symmetric inertia matrix (ixx, ixy, ixz, iyy, iyz, izz)."""
    ixx, ixy, ixz, iyy, iyz, izz = inertia
    return np.linalg.eigvalsh(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], float))


def _inertia(link: Link) -> list[Problem]:
    if link.mass is None or link.mass <= 0:
        return []
    where = f"link {link.name!r}"
    if link.inertia is None:
        return [Problem("inertia", where, f"mass {link.mass:g} kg but no <inertia>", _inertia_fix(link),
                        link.line)]
    e = principal_moments(link.inertia)
    scale = max(abs(float(e[-1])), 1e-300)
    if e[0] <= 1e-12 * scale or e[-1] <= 0:
        shown = ", ".join(f"{v:.3g}" for v in e)
        return [Problem("inertia", where, f"the inertia is not positive definite (principal moments {shown} "
                        "kg·m²): no real body turns like that", _inertia_fix(link), link.line)]
    if e[0] + e[1] < e[2] * (1 - 1e-6):
        return [Problem("inertia", where, f"the principal moments {e[0]:.3g}, {e[1]:.3g}, {e[2]:.3g} kg·m² break "
                        f"the triangle inequality ({e[0]:.3g} + {e[1]:.3g} < {e[2]:.3g}): no real body has them",
                        _inertia_fix(link), link.line)]
    return []


def _inertia_fix(link: Link) -> str:
    size = _size(link)
    m = link.mass or 0.0
    if size is None:
        return "use the inertia of a solid shape of the link's size and mass (e.g. a box: I = m (b² + c²) / 12)"
    a, b, c = size
    return (f"use a solid box's: ixx = {m * (b * b + c * c) / 12:.3g}, iyy = {m * (a * a + c * c) / 12:.3g}, "
            f"izz = {m * (a * a + b * b) / 12:.3g} (I = m (b² + c²) / 12), products 0")


def _axis(joint: Joint) -> list[Problem]:
    if not joint.movable:
        return []
    if math.sqrt(sum(v * v for v in joint.axis)) < 1e-9:
        return [Problem("axis", f"joint {joint.name!r}", "its axis is 0 0 0 (no direction to turn or slide along)",
                        'give a unit direction, e.g. <axis xyz="0 0 1"/>', joint.line)]
    return []


def _limits(joint: Joint) -> list[Problem]:
    where = f"joint {joint.name!r}"
    if joint.type in ("revolute", "prismatic"):
        if not joint.has_limit:
            return [Problem("limits", where, f"a {joint.type} joint without <limit>",
                            '<limit lower="..." upper="..." effort="..." velocity="..."/> (or type="continuous" '
                            "for a wheel)", joint.line)]
        if joint.lower > joint.upper:
            return [Problem("limits", where, f"lower limit {joint.lower:g} is above upper limit {joint.upper:g}",
                            f'swap them: lower="{joint.upper:g}" upper="{joint.lower:g}"', joint.line)]
    return []


def _effort(joint: Joint) -> list[Problem]:
    if not joint.movable or not joint.has_limit:
        return []
    where = f"joint {joint.name!r}"
    unit, vunit = ("N", "m/s") if joint.type == "prismatic" else ("N·m", "rad/s")
    out = []
    if joint.effort is not None and joint.effort <= 0:
        out.append(Problem("effort", where, f"effort {joint.effort:g} {unit}: its motor can push with no force",
                           f"give the motor's largest force in {unit} (effort > 0)", joint.line))
    if joint.velocity is not None and joint.velocity <= 0:
        out.append(Problem("effort", where, f"velocity {joint.velocity:g} {vunit}: the joint may not move",
                           f"give its top speed in {vunit} (velocity > 0)", joint.line))
    return out


def mesh_path(robot: Robot, filename: str) -> Path | None:
    """Where a mesh file name points (relative to the URDF's folder; ``package://PKG/x`` as PyBullet looks for
    it, see :func:`~robokit.robot.expand.package_candidates`), or None when it exists nowhere."""
    from robokit.robot.expand import package_candidates

    folder = robot.path.parent
    name = filename[len("file://"):] if filename.startswith("file://") else filename
    if name.startswith("package://"):
        candidates = package_candidates(folder, name)
    else:
        candidates = [Path(name) if os.path.isabs(name) else folder / name]
    return next((c for c in candidates if c.is_file()), None)


def _meshes(robot: Robot) -> list[Problem]:
    out = []
    for link in robot.links:
        for tag, shapes in (("collision", link.collisions), ("visual", link.visuals)):
            for s in shapes:
                if s.kind == "mesh" and mesh_path(robot, s.filename) is None:
                    out.append(Problem("mesh", f"link {link.name!r}", f"{tag} mesh {s.filename!r} does not exist",
                                       "fix the path (relative to the URDF's folder) or add the file", link.line))
    return out


def config_problems(cfg: Any) -> list[ConfigError]:
    """``robokit validate``: the errors (not the warnings) of every ``[robots.NAME]`` that loads a URDF or xacro
    file, each naming the config, the robot's key and the problem."""
    import pybullet_data

    from robokit.engines.interface import DATA_DIR

    out = []
    for name, body in cfg.robots.items():
        if body.urdf is None:
            continue
        candidates = [Path(body.urdf)] if os.path.isabs(body.urdf) else \
            [cfg.base_dir / body.urdf, DATA_DIR / body.urdf, Path(pybullet_data.getDataPath()) / body.urdf]
        path = next((c for c in candidates if c.is_file()), None)
        if path is None:  # the loader has said so already
            continue
        robot = load(path, body.xacro_args)
        for p in check_robot(robot, fixed_base=body.fixed_base or body.mount is not None):
            if not p.warning:
                out.append(ConfigError(p.text(body.urdf), key=f"robots.{name}", file=cfg.source))
    return out
