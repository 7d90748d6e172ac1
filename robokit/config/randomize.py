"""The ``[randomize]`` section: domain randomisation as config (read by :mod:`robokit.core.randomize`).

Every entry is a distribution drawn once per run (``robokit run``, a sweep trial) and once per episode in
``robokit.gym`` (unless ``per_episode = false``), from a child of the run's seed that nothing else draws from.
"""

from __future__ import annotations

from typing import Annotated, Any

from robokit.config.sections import Bounds, Section, Unit, setting

Range = tuple[float, float]
"""``[low, high]``: a uniform draw between the two (``low <= high``; equal values fix the number)."""


def _check_range(name: str, value: Range | None, low: float | None = None, high: float | None = None) -> None:
    if value is None:
        return
    if value[0] > value[1]:
        raise ValueError(f"{name} {list(value)}: the first value must be <= the second")
    if low is not None and value[0] < low:
        raise ValueError(f"{name} {list(value)}: values must be >= {low:g}")
    if high is not None and value[1] > high:
        raise ValueError(f"{name} {list(value)}: values must be <= {high:g}")


class DistConfig(Section):
    """``[randomize.params]`` entry: ``"actuators.arm.position_gain" = { scale = [0.8, 1.2] }``.

    Exactly one of: ``uniform`` (the value is drawn in [low, high]), ``scale`` (the configured value times a
    factor drawn in [low, high]), ``offset`` (the configured value plus an offset drawn in [low, high], for each
    component of a vector, e.g. a camera's ``eye``) or ``choice`` (one of the listed values).
    """

    uniform: Range | None = setting(None, description="the value, drawn in [low, high] (rounded for an integer "
                                                       "setting)")
    scale: Range | None = setting(None, description="the configured value times a factor in [low, high]")
    offset: Range | None = setting(None, description="the configured value (each component of a vector) plus an "
                                                     "offset in [low, high]")
    choice: tuple[Any, ...] | None = setting(None, description="one of these values, equally likely")

    def check(self) -> None:
        """One kind of distribution; ranges ordered; a choice not empty."""
        given = [k for k in ("uniform", "scale", "offset", "choice") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of 'uniform', 'scale', 'offset' or 'choice'"
                             + (f", not {' and '.join(given)}" if given else ""))
        for name in ("uniform", "scale", "offset"):
            _check_range(name, getattr(self, name))
        if self.choice is not None and not self.choice:
            raise ValueError("choice: give at least one value")


Probability = Annotated[float, Bounds(ge=0.0, le=1.0)]


class RandomizeConfig(Section):
    """``[randomize]``: distributions drawn from the run's seed (once per run; once per episode in robokit.gym)."""

    bodies: tuple[str, ...] = setting((), description="config names ([bodies], [robots]) the body draws apply to; "
                                                       "empty = every body")
    mass_scale: Range | None = setting(None, description="each body's link masses times a factor in [low, high]")
    friction_scale: Range | None = setting(None, description="each body's lateral friction times a factor in "
                                                             "[low, high]")
    restitution: Range | None = setting(None, description="each body's restitution, drawn in [low, high] (0-1)")
    joint_damping: Range | None = setting(None, description="each movable joint's damping, drawn in [low, high] "
                                                            "(N·m·s/rad)")
    colour_hue_deg: float = setting(0.0, ge=0, le=30, description="each primitive's colour hue moved by up to "
                                                                  "± this many degrees")
    colour_saturation: float = setting(0.0, ge=0, le=0.5, description="... its saturation by up to ± this (0-1)")
    colour_value: float = setting(0.0, ge=0, le=0.5, description="... its value (brightness) by up to ± this (0-1)")
    light_azimuth_deg: Range | None = setting(None, description="TinyRenderer light direction: azimuth about +z, "
                                                                "degrees from +x")
    light_elevation_deg: Range | None = setting(None, description="TinyRenderer light direction: elevation above "
                                                                  "the horizon, degrees (90 = overhead)")
    dropout: dict[str, tuple[Unit, Unit]] = setting(
        default_factory=dict, description="sensor name -> [low, high]: the probability, drawn per run, that a "
                                          "reading is not renewed (the previous one is returned)")
    params: dict[str, DistConfig] = setting(
        default_factory=dict, description="'sensors.NAME.KEY' or 'actuators.NAME.KEY' -> a distribution of that "
                                          "plugin setting (gains, forces, noise, camera pose)")
    per_episode: bool = setting(True, description="robokit.gym: draw again at every reset (false: once per env)")

    def check(self) -> None:
        """Ranges ordered and within their physical bounds."""
        _check_range("mass_scale", self.mass_scale, low=0.0)
        _check_range("friction_scale", self.friction_scale, low=0.0)
        _check_range("restitution", self.restitution, low=0.0, high=1.0)
        _check_range("joint_damping", self.joint_damping, low=0.0)
        _check_range("light_azimuth_deg", self.light_azimuth_deg, low=-360.0, high=360.0)
        _check_range("light_elevation_deg", self.light_elevation_deg, low=-90.0, high=90.0)
        for name, value in self.dropout.items():
            _check_range(f"dropout.{name}", value)
        for key in self.params:
            if key.count(".") < 2 or key.split(".", 1)[0] not in ("sensors", "actuators"):
                raise ValueError(f"params: {key!r} is not a plugin setting: write 'sensors.NAME.KEY' or "
                                 "'actuators.NAME.KEY'")
