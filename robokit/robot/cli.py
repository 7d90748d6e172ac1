"""``robokit robot check | new | show``: the robot designer's commands (heavy imports inside each command)."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import argparse

EXIT_OK, EXIT_PROBLEMS = 0, 2


def add_robot_command(sub: Any) -> None:
    """Register ``robokit robot`` and its three sub-commands."""
    robot = sub.add_parser("robot", help="design a robot: check a URDF or xacro file, start one, draw one")
    verbs = robot.add_subparsers(dest="robot_command", metavar="VERB")
    verbs.required = True

    check = verbs.add_parser("check", help="one line per problem of a URDF or xacro file, with its fix")
    check.add_argument("file", help="a URDF or xacro file (a bundled robot or pybullet_data name works too), or a "
                                    "config: each of its [robots] as the config loads it (xacro_args, fixed_base)")
    check.add_argument("--arg", dest="args", action="append", default=[], metavar="NAME=VALUE",
                       help="a xacro argument (repeatable)")
    check.add_argument("--fixed-base", action="store_true", help="the robot is fixed in place (no stability check)")
    check.set_defaults(func=cmd_check)

    new = verbs.add_parser("new", help="write a parametric xacro robot and a config that drives it")
    new.add_argument("name", help="the robot's name (letters, digits, _)")
    new.add_argument("--kind", required=True, choices=("diffdrive", "arm", "gripper-arm"))
    new.add_argument("-o", "--out", metavar="DIR", help="the folder to write to (default: ./NAME)")
    new.add_argument("--force", action="store_true", help="write over existing files")
    new.set_defaults(func=cmd_new)

    show = verbs.add_parser("show", help="draw a robot from three sides with its joint frames and axes")
    show.add_argument("file", help="a URDF or xacro file, or a config (its first robot, with its xacro_args)")
    show.add_argument("--arg", dest="args", action="append", default=[], metavar="NAME=VALUE",
                      help="a xacro argument (repeatable)")
    show.add_argument("-o", "--output", default="robot.png", metavar="PNG")
    show.add_argument("--size", type=int, default=360, metavar="PX", help="each view's height in pixels")
    show.set_defaults(func=cmd_show)


def xacro_args(items: list[str]) -> dict[str, str]:
    """``NAME=VALUE`` options as a dict."""
    from robokit.errors import UserError

    out = {}
    for item in items:
        name, eq, value = item.partition("=")
        if not eq or not name:
            raise UserError(f"--arg {item!r}: expected NAME=VALUE")
        out[name.strip()] = value.strip()
    return out


def find_file(name: str) -> str:
    """A path as given, else a bundled robot or a ``pybullet_data`` name."""
    from pathlib import Path

    import pybullet_data

    from robokit.errors import UserError

    data = Path(__file__).resolve().parent.parent / "data"
    for cand in (Path(name), data / name, Path(pybullet_data.getDataPath()) / name):
        if cand.is_file():
            return str(cand)
    raise UserError(f"{name}: no such file (looked here, in robokit's robots and in pybullet_data)")


def robots_of(file: str, items: list[str]) -> list[tuple[str, str, dict[str, Any], bool | None]]:
    """What ``check`` and ``show`` look at: ``(label, path, xacro arguments, fixed base)`` for a robot file (the
    ``--arg`` options), or for each ``[robots.NAME]`` of a config (its own ``xacro_args`` and ``fixed_base``)."""
    from pathlib import Path

    from robokit.errors import UserError

    if not file.endswith(".toml"):
        return [(file, find_file(file), dict(xacro_args(items)), None)]
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - robokit's dependency on older Pythons
        import tomli as tomllib

    try:
        with open(file, "rb") as f:
            robots = tomllib.load(f).get("robots", {})
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise UserError(f"{file}: cannot read the config: {exc}") from None
    out: list[tuple[str, str, dict[str, Any], bool | None]] = []
    for name, table in robots.items():
        if isinstance(table, dict) and isinstance(table.get("urdf"), str):
            urdf = table["urdf"]
            beside = Path(file).parent / urdf
            path = str(beside) if beside.is_file() else find_file(urdf)
            fixed = bool(table.get("fixed_base", False)) or "mount" in table
            out.append((f"{file} [robots.{name}] {urdf}", path, dict(table.get("xacro_args", {})), fixed))
    if not out:
        raise UserError(f"{file}: no [robots.NAME] with a urdf file")
    return out


def cmd_check(args: argparse.Namespace) -> int:
    """``robokit robot check FILE``: print each problem on one line; exit 2 when there is an error."""
    from robokit.robot.check import check_robot, load

    failed = 0
    for label, path, arguments, fixed in robots_of(args.file, args.args):
        robot = load(path, arguments)
        problems = check_robot(robot, fixed_base=True if args.fixed_base else fixed)
        for p in problems:
            print(p.text(label), file=sys.stderr if not p.warning else sys.stdout)
        errors = [p for p in problems if not p.warning]
        if errors:
            print(f"{label}: {len(errors)} problem{'s' * (len(errors) != 1)}", file=sys.stderr)
            failed += 1
            continue
        warned = f", {len(problems)} warning{'s' * (len(problems) != 1)}" if problems else ""
        print(f"{label}: ok ({len(robot.links)} links, {len(robot.joints)} joints{warned})")
    return EXIT_PROBLEMS if failed else EXIT_OK


def cmd_new(args: argparse.Namespace) -> int:
    """``robokit robot new NAME --kind KIND``: write the xacro and the config; say what to run next."""
    from pathlib import Path

    from robokit.robot.scaffold import new_robot

    xacro_path, config_path = new_robot(args.name, args.kind, Path(args.out) if args.out else None, force=args.force)
    print(f"wrote {xacro_path} and {config_path}")
    print(f"next: robokit robot check {xacro_path}")
    print(f"      robokit run {config_path}")
    return EXIT_OK


def cmd_show(args: argparse.Namespace) -> int:
    """``robokit robot show FILE -o robot.png``: three views with joint frames and axes labelled."""
    from robokit.robot.check import load
    from robokit.robot.show import draw_robot

    _, path, arguments, _ = robots_of(args.file, args.args)[0]
    out = draw_robot(load(path, arguments), args.output, height=args.size)
    print(f"wrote {out}")
    return EXIT_OK


def inspect_path(name: str) -> str:
    """What ``robokit inspect`` loads: a xacro file expanded (default arguments), anything else as given."""
    from robokit.robot.expand import expand_xacro, is_xacro

    return str(expand_xacro(find_file(name))) if is_xacro(name) else name


def inspect_links(world: Any, urdf: str) -> list[dict[str, Any]]:
    """Each link of the loaded ``robot``: name, mass (kg, as the file gives it; the engine's default for a link
    without one), centre of mass (m, link frame) and inertia (kg·m², about the centre of mass, as the
    file gives it; None when the file has none)."""
    from robokit.robot.model import read_robot

    model = read_robot(world.resolve_urdf(urdf))
    rows = []
    for index, name in enumerate(world.link_names("robot"), start=-1):
        link = model.link(name)
        mass = link.mass if link is not None and link.mass is not None else world.mass("robot", index)
        rows.append({"link": name, "mass": float(mass),
                     "com": list(link.inertial_xyz) if link else None,
                     "inertia": dict(zip(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), link.inertia, strict=True))
                     if link and link.inertia else None})
    return rows


def print_links(rows: list[dict[str, Any]]) -> None:
    """The link table under ``robokit inspect``'s joint table."""
    total = sum(r["mass"] for r in rows)
    print(f"links: total mass {total:.3f} kg")
    print("{:<28} {:>9}  {:>10} {:>10} {:>10}  {}".format("link", "mass kg", "ixx", "iyy", "izz",
                                                          "ixy ixz iyz (kg·m²)"))
    for r in rows:
        i = r["inertia"]
        moments = (f"{i['ixx']:>10.3g} {i['iyy']:>10.3g} {i['izz']:>10.3g}  {i['ixy']:.3g} {i['ixz']:.3g} "
                   f"{i['iyz']:.3g}") if i else f"{'(none in the file)':>32}"
        print(f"{r['link']:<28} {r['mass']:>9.3f}  {moments}")
