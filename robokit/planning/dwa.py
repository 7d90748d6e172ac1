"""A dynamic-window local planner for a differential drive (Fox, Burgard & Thrun, 1997).

Every control step it samples speed pairs ``(v, omega)`` reachable from the current ones within one step of the
acceleration limits (the *dynamic window*), rolls each out as an arc for ``horizon`` seconds, throws away those
that would bring the robot's disk closer than ``radius`` to an obstacle (unless they keep its clearance from
falling: turning in place, backing away), and takes the cheapest of the rest: heading towards a point ahead on
the global path (the *carrot*), the arc's end near the carrot, clearance along the arc, and speed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydantic import Field

from robokit.config import Schema
from robokit.msgs.mobile import Pose2D, Twist


class DwaConfig(Schema):
    """Dynamic-window parameters. Speeds in m/s and rad/s, accelerations in m/s^2 and rad/s^2, times in s.

    Attributes:
        max_speed: Top forward speed.
        max_turn_rate: Top yaw rate.
        max_accel: Forward acceleration limit (also braking).
        max_yaw_accel: Yaw acceleration limit.
        horizon: How far ahead each arc is rolled out.
        dt: Time between rolled-out poses.
        speeds: Forward speeds sampled across the window.
        turn_rates: Yaw rates sampled across the window.
        heading_weight: Cost per radian/pi of heading error to the carrot at the arc's end.
        distance_weight: Cost per lookahead-length of distance from the arc's end to the carrot.
        clearance_weight: Cost of an arc that passes at the hard limit (falls to 0 at ``radius + soft``).
        speed_weight: Cost of standing still (falls to 0 at ``max_speed``).
        soft: Clearance beyond the robot's radius that still costs, m.
        arrive_gain: Forward speed is capped at this times the distance left to the goal (+ 0.03 m/s), 1/s.
    """

    max_speed: float = Field(0.4, gt=0)
    max_turn_rate: float = Field(1.5, gt=0)
    max_accel: float = Field(1.0, gt=0)
    max_yaw_accel: float = Field(4.0, gt=0)
    horizon: float = Field(1.5, gt=0)
    dt: float = Field(0.1, gt=0)
    speeds: int = Field(7, ge=2, le=50)
    turn_rates: int = Field(15, ge=3, le=100)
    heading_weight: float = Field(1.0, ge=0)
    distance_weight: float = Field(1.0, ge=0)
    clearance_weight: float = Field(0.6, ge=0)
    speed_weight: float = Field(0.3, ge=0)
    soft: float = Field(0.25, ge=0)
    arrive_gain: float = Field(1.0, gt=0)


@dataclass
class Choice:
    """The chosen command and how it scored."""

    twist: Twist
    clearance: float
    admissible: int


class DynamicWindow:
    """Chooses ``(v, omega)`` each control step (see the module docstring).

    Args:
        cfg: Parameters.
        radius: The robot's disk radius, m: arcs closer than this to an obstacle are not taken.
        period: Seconds between calls (the window is what the limits allow in that time).
    """

    def __init__(self, cfg: DwaConfig, radius: float, period: float) -> None:
        self.cfg = cfg
        self.radius = radius
        self.period = period
        self.ts = np.arange(1, max(1, round(cfg.horizon / cfg.dt)) + 1) * cfg.dt

    def window(self, v: float, omega: float, dist: float) -> tuple[np.ndarray, np.ndarray]:
        """Sampled speeds and yaw rates reachable within one period from ``(v, omega)``; forward speed capped
        near the goal (``dist`` m left)."""
        c = self.cfg
        dv, dw = c.max_accel * self.period, c.max_yaw_accel * self.period
        v_lo, v_hi = max(0.0, v - dv), min(c.max_speed, v + dv)
        v_hi = max(v_lo, min(v_hi, c.arrive_gain * dist + 0.03))
        w_lo, w_hi = max(-c.max_turn_rate, omega - dw), min(c.max_turn_rate, omega + dw)
        vs = np.unique(np.append(np.linspace(v_lo, v_hi, c.speeds), 0.0 if v_lo == 0.0 else v_lo))
        ws = np.unique(np.append(np.linspace(w_lo, w_hi, c.turn_rates), min(max(0.0, w_lo), w_hi)))
        return vs, ws

    def rollout(self, pose: Pose2D, vs: np.ndarray, ws: np.ndarray) -> np.ndarray:
        """Poses along each arc: array ``(len(vs) * len(ws), len(ts), 3)`` of (x, y, yaw)."""
        v, w = (a.ravel()[:, None] for a in np.meshgrid(vs, ws, indexing="ij"))
        t = self.ts[None, :]
        yaw = pose[2] + w * t
        straight = np.abs(w) < 1e-6
        safe_w = np.where(straight, 1.0, w)
        x = np.where(straight, pose[0] + v * t * math.cos(pose[2]),
                     pose[0] + v / safe_w * (np.sin(yaw) - math.sin(pose[2])))
        y = np.where(straight, pose[1] + v * t * math.sin(pose[2]),
                     pose[1] - v / safe_w * (np.cos(yaw) - math.cos(pose[2])))
        return np.stack([x, y, yaw], axis=-1)

    def choose(self, pose: Pose2D, v: float, omega: float, carrot: tuple[float, float], dist: float,
               lookahead: float, clearance: Callable[[np.ndarray], np.ndarray]) -> Choice:
        """The best admissible command.

        Args:
            pose: Robot pose (x, y, yaw), world frame.
            v: Current forward speed, m/s.
            omega: Current yaw rate, rad/s.
            carrot: Point to head for, world (x, y), m.
            dist: Distance left to the goal, m.
            lookahead: Normal distance to the carrot, m (scales the distance cost).
            clearance: Clearance (m) at world points ``(..., 2)``.
        """
        c = self.cfg
        vs, ws = self.window(v, omega, dist)
        arcs = self.rollout(pose, vs, ws)
        vv, ww = (a.ravel() for a in np.meshgrid(vs, ws, indexing="ij"))
        clear = clearance(arcs[:, :, :2]).min(axis=1)
        now = float(clearance(np.array([pose[0], pose[1]])))
        ok = (clear >= self.radius) | ((clear >= now - 1e-6) & (vv <= 0.05))
        end = arcs[:, -1, :]
        to_carrot = np.arctan2(carrot[1] - end[:, 1], carrot[0] - end[:, 0])
        heading = np.abs((to_carrot - end[:, 2] + math.pi) % (2 * math.pi) - math.pi) / math.pi
        gap = np.hypot(carrot[0] - end[:, 0], carrot[1] - end[:, 1]) / max(lookahead, 1e-6)
        tight = np.clip((self.radius + c.soft - clear) / max(c.soft, 1e-6), 0.0, 1.0)
        cost = (c.heading_weight * heading + c.distance_weight * gap + c.clearance_weight * tight
                + c.speed_weight * (1.0 - vv / c.max_speed))
        cost = np.where(ok, cost, np.inf)
        k = int(np.argmin(cost))
        if not np.isfinite(cost[k]):  # nothing admissible: stop
            return Choice(Twist(0.0, 0.0), now, 0)
        return Choice(Twist(float(vv[k]), float(ww[k])), float(clear[k]), int(ok.sum()))
