"""A URDF read into plain data: links (mass, inertia, shapes) and joints (type, frames, axis, limits).

Only what the checker and the drawing need is read; nothing here imports an engine. Lengths in metres, masses in
kilograms, inertias in kg·m², angles in radians, as the URDF writes them.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from robokit.errors import UserError


@dataclass(frozen=True)
class Shape:
    """One ``<collision>`` or ``<visual>`` geometry: ``kind`` is box, cylinder, sphere or mesh."""

    kind: str
    size: tuple[float, ...] = ()
    """box: (x, y, z) edge lengths; cylinder: (radius, length); sphere: (radius,); mesh: the scale."""
    filename: str = ""
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass
class Link:
    """A ``<link>``: its inertial block (None when absent) and its shapes."""

    name: str
    line: int
    mass: float | None = None
    inertia: tuple[float, float, float, float, float, float] | None = None
    """(ixx, ixy, ixz, iyy, iyz, izz) about the inertial origin."""
    inertial_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    collisions: list[Shape] = field(default_factory=list)
    visuals: list[Shape] = field(default_factory=list)


@dataclass
class Joint:
    """A ``<joint>``: parent and child links, the child frame's origin in the parent's, axis and limits."""

    name: str
    line: int
    type: str
    parent: str
    child: str
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    has_limit: bool = False
    lower: float = 0.0
    upper: float = 0.0
    effort: float | None = None
    velocity: float | None = None

    @property
    def movable(self) -> bool:
        """True for joints a motor can drive (revolute, continuous, prismatic)."""
        return self.type in ("revolute", "continuous", "prismatic")


@dataclass
class Robot:
    """The whole description: ``path`` is the URDF read (for a xacro file, the expanded URDF)."""

    name: str
    path: Path
    links: list[Link]
    joints: list[Joint]
    source: Path | None = None
    """The file the user named (the xacro file when ``path`` was expanded from one)."""

    def link(self, name: str) -> Link | None:
        """The first link called ``name``, or None."""
        return next((lk for lk in self.links if lk.name == name), None)

    def roots(self) -> list[str]:
        """Links that are no joint's child, in file order (a well-formed tree has exactly one)."""
        children = {j.child for j in self.joints}
        return [lk.name for lk in self.links if lk.name not in children]

    def children(self, link: str) -> list[Joint]:
        """Joints whose parent is ``link``."""
        return [j for j in self.joints if j.parent == link]

    def wheels(self) -> list[Joint]:
        """Continuous joints whose child link has collision geometry: the wheels of a mobile base."""
        out = []
        for j in self.joints:
            child = self.link(j.child)
            if j.type == "continuous" and child is not None and child.collisions:
                out.append(j)
        return out


def _floats(text: str | None, n: int, default: tuple[float, ...], where: str) -> tuple[float, ...]:
    """``n`` numbers from ``text`` (``where`` names the attribute for messages)."""
    del where
    if text is None:
        return default
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:  # as PyBullet reads it: what is not a number is left at the default
        return default
    return values if len(values) == n else default


def _number(elem: ET.Element | None, attr: str, where: str) -> float | None:
    if elem is None or elem.get(attr) is None:
        return None
    return float(_floats(elem.get(attr), 1, (0.0,), f"{where} {attr}")[0])


def _origin(elem: ET.Element, where: str) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    origin = elem.find("origin")
    if origin is None:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    xyz = _floats(origin.get("xyz"), 3, (0.0, 0.0, 0.0), f"{where} origin xyz")
    rpy = _floats(origin.get("rpy"), 3, (0.0, 0.0, 0.0), f"{where} origin rpy")
    return (xyz[0], xyz[1], xyz[2]), (rpy[0], rpy[1], rpy[2])


def _shape(elem: ET.Element, where: str) -> Shape | None:
    geom = elem.find("geometry")
    if geom is None or len(geom) == 0:
        return None
    g = geom[0]
    xyz, rpy = _origin(elem, where)
    if g.tag == "box":
        return Shape("box", _floats(g.get("size"), 3, (0.0, 0.0, 0.0), f"{where} box size"), xyz=xyz, rpy=rpy)
    if g.tag == "cylinder" or g.tag == "capsule":
        r, h = _number(g, "radius", where) or 0.0, _number(g, "length", where) or 0.0
        return Shape(g.tag, (r, h), xyz=xyz, rpy=rpy)
    if g.tag == "sphere":
        return Shape("sphere", (_number(g, "radius", where) or 0.0,), xyz=xyz, rpy=rpy)
    if g.tag == "mesh":
        scale = _floats(g.get("scale"), 3, (1.0, 1.0, 1.0), f"{where} mesh scale")
        return Shape("mesh", scale, filename=g.get("filename", ""), xyz=xyz, rpy=rpy)
    return None


def _link(elem: ET.Element, line: int) -> Link:
    name = elem.get("name", "")
    where = f"link {name!r}"
    link = Link(name=name, line=line)
    inertial = elem.find("inertial")
    if inertial is not None:
        link.mass = _number(inertial.find("mass"), "value", f"{where} mass")
        link.inertial_xyz = _origin(inertial, where)[0]
        inertia = inertial.find("inertia")
        if inertia is not None:
            values = [_number(inertia, k, f"{where} inertia") or 0.0 for k in ("ixx", "ixy", "ixz", "iyy", "iyz",
                                                                              "izz")]
            link.inertia = (values[0], values[1], values[2], values[3], values[4], values[5])
    for tag, shapes in (("collision", link.collisions), ("visual", link.visuals)):
        for sub in elem.findall(tag):
            shape = _shape(sub, f"{where} {tag}")
            if shape is not None:
                shapes.append(shape)
    return link


def _joint(elem: ET.Element, line: int) -> Joint:
    name = elem.get("name", "")
    where = f"joint {name!r}"
    parent, child = elem.find("parent"), elem.find("child")
    xyz, rpy = _origin(elem, where)
    joint = Joint(name=name, line=line, type=elem.get("type", ""), xyz=xyz, rpy=rpy,
                  parent="" if parent is None else parent.get("link", ""),
                  child="" if child is None else child.get("link", ""))
    axis = elem.find("axis")
    if axis is not None:
        values = _floats(axis.get("xyz"), 3, (1.0, 0.0, 0.0), f"{where} axis")
        joint.axis = (values[0], values[1], values[2])
    limit = elem.find("limit")
    if limit is not None:
        joint.has_limit = True
        joint.lower = _number(limit, "lower", where) or 0.0
        joint.upper = _number(limit, "upper", where) or 0.0
        joint.effort = _number(limit, "effort", where)
        joint.velocity = _number(limit, "velocity", where)
    return joint


def _lines(text: str, tag: str) -> list[int]:
    """1-based line numbers of every ``<tag `` opening in ``text``, in order."""
    out: list[int] = []
    start = 0
    needle = f"<{tag}"
    while True:
        i = text.find(needle, start)
        if i < 0:
            return out
        after = text[i + len(needle): i + len(needle) + 1]
        if after in (" ", "\n", "\t", ">", "/"):
            out.append(text.count("\n", 0, i) + 1)
        start = i + 1


def read_robot(path: str | Path, *, source: Path | None = None) -> Robot:
    """Read a URDF file (already expanded: see :func:`robokit.robot.expand.expand_xacro` for xacro).

    Raises:
        UserError: The file is missing or is not a URDF (one line naming the file and, for XML errors, the line).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        root = ET.fromstring(text.rstrip("\x00\r\n\t "))  # a trailing NUL (pybullet_data's humanoid) is no XML
    except ET.ParseError as exc:
        line = exc.position[0]
        raise UserError(f"{path}:{line}: not well-formed XML: {exc}") from None
    if root.tag != "robot":
        raise UserError(f"{path}: not a URDF: the top element is <{root.tag}>, not <robot>")
    # Direct children only, as the URDF specification reads them (a <link> inside <gazebo> is not a link).
    link_lines, joint_lines = iter(_top_level_lines(text, root, "link")), iter(_top_level_lines(text, root, "joint"))
    links = [_link(e, next(link_lines, 0)) for e in root.findall("link")]
    joints = [_joint(e, next(joint_lines, 0)) for e in root.findall("joint")]
    return Robot(name=root.get("name", path.stem), path=path, links=links, joints=joints, source=source)


def _top_level_lines(text: str, root: ET.Element, tag: str) -> list[int]:
    """Line numbers of ``root``'s direct ``<tag>`` children. ElementTree keeps no line numbers; nested elements of
    the same tag (a ``<link>`` inside ``<gazebo>``, ``<joint>`` inside ``<transmission>``) are rare, so the
    openings are matched in order and any nested ones skipped by count."""
    lines = _lines(text, tag)
    nested = sum(1 for e in root.iter(tag)) - len(root.findall(tag))
    if nested == 0:
        return lines
    return [0] * len(root.findall(tag))  # line numbers unknown: names alone identify the element
