"""The sort's reach check for ``robokit validate``: the moves the run will make, planned by the arm itself.

A run of the sort moves the tool to the look position, then for each object (the nearest to the gripper first):
above it (``approach_height``), down to the grasp, up to the transport altitude, across to above its bin's next
slot, down to the release height, up by ``retreat_height``. The arm plans every one of these moves from where the
last one ended, on a straight path, waypoint by waypoint, with its configured IK tolerance
(:meth:`robokit_plugins.ik_arm.IkArm.check_moves`). This module lists the same moves from the scene as spawned, so
validate refuses exactly the layouts whose moves the arm would reject, naming the object or the bin.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from robokit.msgs.arm import cube_grasp_yaw

Vec3 = tuple[float, float, float]
STEPS = ("above the object", "down to the grasp", "up to the transport altitude", "across to above the bin",
         "down to release in the bin", "up out of the bin")
"""What each move of one pick-and-place is (the first two concern the object, the rest its bin)."""
OVER_BIN = 3
"""The index of the move that brings the object over its bin slot: a run whose arm cannot make the moves after it
(lowering into the bin, leaving it) still ends with the object in the bin — the sort opens the gripper when a pick
fails, over the slot — so only the moves up to this one decide whether a bin is within reach."""


@dataclass(frozen=True)
class Move:
    """One planned move: the tool position (metres, world) and yaw (radians), the object and what it is for."""

    position: Vec3
    yaw: float
    object: str
    colour: str
    step: int  # index into STEPS; -1 = the look position


@dataclass(frozen=True)
class Pick:
    """One object's pick-and-place: the moves to the object, then one way to place it per bin slot it may get
    (the sort gives each attempt the bin's next slot)."""

    object: str
    colour: str
    to_object: list[Move]
    placings: list[list[Move]]


def sort_picks(look: Vec3, objects: Sequence[tuple[str, str, Vec3, float]], slots: Mapping[str, Sequence[Vec3]],
               pp: Any, attempts: int) -> list[Pick]:
    """The picks of a sort, nearest object to the gripper first, each with the slots its ``attempts`` would use.

    Args:
        look: The look position. objects: (name, colour, centre position, yaw) of each sortable object.
        slots: Each colour's bin slots (object centres), used in order. pp: The pick_place config (heights).
    """
    used = dict.fromkeys(slots, 0)
    here, left, picks = look, list(objects), []
    while left:
        name, colour, (x, y, z), yaw = min(left, key=lambda o: math.dist(here[:2], o[2][:2]))
        left.remove((name, colour, (x, y, z), yaw))
        grasp_yaw = cube_grasp_yaw(yaw, 0.0)
        gz = z + pp.grasp_offset
        placings = []
        for k in range(max(1, attempts)):
            sx, sy, sz = slots[colour][(used[colour] + k) % len(slots[colour])]
            altitude = max(gz, sz + pp.grasp_offset) + pp.lift_height
            release = sz + pp.grasp_offset
            targets = [(x, y, altitude), (sx, sy, altitude), (sx, sy, release + pp.place_clearance),
                       (sx, sy, release + pp.retreat_height)]
            placings.append([Move(t, grasp_yaw, name, colour, 2 + i) for i, t in enumerate(targets)])
        used[colour] += 1
        to_object = [Move((x, y, gz + pp.approach_height), grasp_yaw, name, colour, 0),
                     Move((x, y, gz), grasp_yaw, name, colour, 1)]
        picks.append(Pick(name, colour, to_object, placings))
        here = placings[0][-1].position
    return picks


def _plan(moves: Sequence[Move], check_moves: Any, here: Any, fallbacks: Sequence[Any]) -> tuple[str, Move | None,
                                                                                                Any]:
    """Plan ``moves`` one by one from ``here``; a move that fails is planned again from each of ``fallbacks`` (a
    run recovers from where it then is). Returns ("" or the first reason, the move it concerns, the end). A move
    after the object is over its bin (:data:`OVER_BIN`) that fails ends the plan without a reason: the object is
    dropped into the bin from there."""
    for move in moves:
        target = [(move.position, move.yaw)]
        (reason,), end = check_moves(target, here)
        for start in fallbacks:
            if not reason:
                break
            (again,), end = check_moves(target, start)
            reason = reason if again else ""
        if reason:
            return ("", None, here) if move.step > OVER_BIN else (reason, move, here)
        here = end
    return "", None, here


def unreachable(look: Vec3, picks: Sequence[Pick], check_moves: Any) -> list[tuple[Move, str]]:
    """The moves the arm could not make, the first for each object (and the look position), with the reason.

    Each move is planned from where the previous one ended. A run that fails a move recovers (the sort goes back to
    the look position and picks again, with the bin's next slot), and its arm then starts from a slightly different
    configuration: a move counts as unreachable only if it also fails from the look position and from the ready
    pose, and a placing only if it fails in every slot the object's attempts would use.
    """
    (why,), at_look = check_moves([(look, 0.0)])
    out = [(Move(look, 0.0, "", "", -1), why)] if why else []
    here = at_look
    for pick in picks:
        reason, move, here = _plan(pick.to_object, check_moves, here, (at_look, None))
        if reason:
            out.append((move, reason))  # type: ignore[arg-type]
            continue
        first: tuple[str, Move | None] | None = None
        for placing in pick.placings:
            reason, move, end = _plan(placing, check_moves, here, (at_look, None))
            if not reason:
                here, first = end, None
                break
            first = first or (reason, move)
        if first is not None:
            out.append((first[1], first[0]))  # type: ignore[arg-type]
    return out
