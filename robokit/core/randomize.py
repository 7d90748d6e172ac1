"""Domain randomisation: draw a config's ``[randomize]`` distributions and apply them to a World and its plugins.

The draws come from one generator per run, a child of the run's seed made with ``SeedSequence(seed,
spawn_key=(STREAM,))``: not the World's generator, so a config without ``[randomize]`` draws exactly what it drew
before, and a config with one scatters its bodies, seeds its plugins and adds its noise exactly as without it. The
same seed gives the same draws in ``robokit run``, a sweep trial and ``robokit.gym`` (``reset(seed=s)``).

What is drawn, in this order (each a fixed number of draws, so adding a body changes only what follows it):

1. per body (the World's bodies in creation order, those named in ``bodies`` or all): a mass factor, a friction
   factor, a restitution; per movable joint of it a damping; for a primitive (``shape = ...``) a colour jitter;
2. the light direction (azimuth, elevation) that every TinyRenderer camera uses (``World.render_options``);
3. per ``dropout`` sensor, its probability; 4. per ``params`` entry, its value.

Plugin settings (``params``) are changed the way the user would change them: the drawn value replaces the
configured one and the plugin's own schema validates it again before the plugin is built. That is the whole hook
a plugin needs: any numeric setting of any sensor or actuator (``ik_arm``'s ``position_gain`` and ``max_force``,
``joint_control``'s gains, ``diff_drive``'s ``max_wheel_force``, ``lidar``'s ``range_noise``, a camera's ``eye``)
can be randomised without the plugin knowing.
"""

from __future__ import annotations

import colorsys
import math
import zlib
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from robokit.errors import ConfigError

if TYPE_CHECKING:
    from robokit.config import ComponentSpec, Config
    from robokit.config.randomize import DistConfig, RandomizeConfig
    from robokit.core.world import World

STREAM = 0x72616E64
"""The spawn key of the randomisation stream (``"rand"``): a child of the run's seed that the World's own
``spawn`` counter (0, 1, 2 ... one per component) never reaches."""


def generator(seed: int) -> np.random.Generator:
    """The randomisation generator of a run with this seed."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(int(seed), spawn_key=(STREAM,))))


def _u(rng: np.random.Generator, bounds: tuple[float, float] | None) -> float | None:
    return None if bounds is None else float(rng.uniform(bounds[0], bounds[1]))


class Randomizer:
    """Draws a ``[randomize]`` section and applies the draws; keeps the nominal values to apply a redraw over.

    Args:
        spec: The validated section.
        config: The whole config (which bodies are primitives, their colours, the plugin settings).
    """

    def __init__(self, spec: RandomizeConfig, config: Config) -> None:
        self.spec = spec
        self.config = config
        self.drawn: dict[str, Any] = {}
        """The values of the latest draw (JSON-ready): what the result and the run record keep."""
        self._nominal: dict[tuple[int, int], tuple[float, float, float]] = {}
        self._held: list[list[Any]] = []

    # ----------------------------------------------------------------- drawing
    def draw(self, world: World, body_keys: Mapping[str, str], rng: np.random.Generator) -> dict[str, Any]:
        """Draw every distribution (see the module's order); returns and keeps :attr:`drawn`."""
        spec = self.spec
        bodies: dict[str, Any] = {}
        for name in world.body_names:
            if spec.bodies and body_keys.get(name, "").split(".")[-1] not in spec.bodies:
                continue
            entry: dict[str, Any] = {"mass_scale": _u(rng, spec.mass_scale),
                                     "friction_scale": _u(rng, spec.friction_scale),
                                     "restitution": _u(rng, spec.restitution)}
            if spec.joint_damping is not None:
                entry["joint_damping"] = {j.name: _u(rng, spec.joint_damping) for j in world.joints(name)
                                          if j.movable}
            rgba = self._colour(name, body_keys, rng)
            if rgba is not None:
                entry["rgba"] = rgba
            bodies[name] = {k: v for k, v in entry.items() if v is not None}
        drawn: dict[str, Any] = {"bodies": bodies}
        if spec.light_azimuth_deg is not None or spec.light_elevation_deg is not None:
            azimuth = _u(rng, spec.light_azimuth_deg or (0.0, 0.0))
            elevation = _u(rng, spec.light_elevation_deg or (90.0, 90.0))
            assert azimuth is not None and elevation is not None
            drawn["light_direction"] = light_direction(azimuth, elevation)
        drawn["dropout"] = {name: _u(rng, bounds) for name, bounds in spec.dropout.items()}
        drawn["params"] = {key: self._param(key, dist, rng) for key, dist in spec.params.items()}
        self.drawn = drawn
        return drawn

    def _colour(self, name: str, body_keys: Mapping[str, str], rng: np.random.Generator) -> list[float] | None:
        spec = self.spec
        if not (spec.colour_hue_deg or spec.colour_saturation or spec.colour_value):
            return None
        section, _, key = body_keys.get(name, "").partition(".")
        body = (self.config.bodies if section == "bodies" else self.config.robots).get(key)
        if body is None or body.shape is None:
            return None
        dh, ds, dv = rng.uniform(-1.0, 1.0, 3) * (spec.colour_hue_deg / 360.0, spec.colour_saturation,
                                                  spec.colour_value)
        return jitter_colour(body.rgba, float(dh), float(ds), float(dv))

    def _param(self, dotted: str, dist: DistConfig, rng: np.random.Generator) -> Any:
        section, name, key = dotted.split(".", 2)
        current = getattr(self._spec_of(section, name).params, key)
        where = f"randomize.params.{dotted}"
        if dist.choice is not None:
            chosen = dist.choice[int(rng.integers(len(dist.choice)))]
            return list(chosen) if isinstance(chosen, tuple) else chosen
        if dist.uniform is not None:
            value: Any = float(rng.uniform(*dist.uniform))
            return round(value) if isinstance(current, int) and not isinstance(current, bool) else value
        if isinstance(current, bool) or not isinstance(current, (int, float, tuple)) or current is None:
            raise ConfigError(f"{'scale' if dist.scale else 'offset'} needs a configured number (or list of "
                              f"numbers), and {dotted} is {current!r}: use 'uniform' or 'choice'", key=where)
        bounds = dist.scale if dist.scale is not None else dist.offset
        assert bounds is not None
        values = np.asarray(current, float)
        drawn = rng.uniform(bounds[0], bounds[1], values.shape)
        out = values * drawn if dist.scale is not None else values + drawn
        return [float(v) for v in out] if isinstance(current, tuple) else float(out)

    def _spec_of(self, section: str, name: str) -> ComponentSpec:
        specs = self.config.sensors if section == "sensors" else self.config.actuators
        return next(s for s in specs if s.name == name)

    # ----------------------------------------------------------------- applying
    def apply_world(self, world: World) -> None:
        """Set the drawn masses, frictions, restitutions, joint dampings, colours and light on the World
        (factors act on the values the bodies had when first applied, so a redraw does not compound)."""
        for name, entry in self.drawn["bodies"].items():
            if not world.has_body(name):
                continue
            bid = world.body(name)
            joints = world.joints(bid)
            for link in range(-1, len(joints)):
                self._apply_link(world, bid, link, entry)
            for joint, damping in entry.get("joint_damping", {}).items():
                world.set_dynamics(bid, world.joint(bid, joint).index, joint_damping=damping)
            if "rgba" in entry:
                world.set_visual_rgba(bid, entry["rgba"])
        if "light_direction" in self.drawn:
            world.render_options["lightDirection"] = list(self.drawn["light_direction"])
        for held in self._held:  # a new episode starts with fresh readings
            held.clear()

    def _apply_link(self, world: World, bid: int, link: int, entry: Mapping[str, Any]) -> None:
        """Set a link's drawn mass, friction and restitution; values already in place are not set again (setting
        a mass, even the same one, changes how the link is solved)."""
        mass, friction, restitution = self._nominal_of(world, bid, link)
        wanted = {"mass": mass * entry["mass_scale"] if "mass_scale" in entry and mass > 0 else mass,
                  "lateral_friction": friction * entry.get("friction_scale", 1.0),
                  "restitution": entry.get("restitution", restitution)}
        now = world.dynamics(bid, link)
        changed = {k: v for k, v in wanted.items() if v != now[k]}
        if changed:
            world.set_dynamics(bid, link, **changed)

    def _nominal_of(self, world: World, bid: int, link: int) -> tuple[float, float, float]:
        if (bid, link) not in self._nominal:
            info = world.dynamics(bid, link)
            self._nominal[(bid, link)] = (info["mass"], info["lateral_friction"], info["restitution"])
        return self._nominal[(bid, link)]

    def params_for(self, spec: ComponentSpec) -> Any:
        """The component's settings with the drawn ``params`` in place, validated again by its schema."""
        prefix = f"{spec.kind}s.{spec.name}."
        update = {k[len(prefix):]: v for k, v in self.drawn.get("params", {}).items() if k.startswith(prefix)}
        if not update or spec.params is None:
            return spec.params
        from robokit.config import validate_model

        section, name = spec.key.split(".", 1)
        given = {k: v for k, v in self.config.raw[section][name].items() if k not in ("type", "rate_hz")}
        try:
            return validate_model(type(spec.params), {**given, **update}, spec.key)
        except ConfigError as exc:
            keys = ", ".join(f"randomize.params.{spec.key}.{k}" for k in update)
            raise ConfigError(f"a drawn value is refused ({exc.key}: {exc.message})", key=keys,
                              file=self.config.source) from None

    def install_dropout(self, name: str, component: Any, world: World, seed: int) -> None:
        """Make a sensor's reading stale with the drawn probability: at a tick that drops, ``read()`` returns the
        previous reading. Whether a tick drops is drawn from that tick alone (seed, sensor, tick), never from how
        often the sensor is read."""
        if name not in self.drawn["dropout"]:
            return
        read: Callable[[], Any] = component.read
        last: list[Any] = []
        self._held.append(last)
        salt = zlib.crc32(name.encode("utf-8"))

        def dropping_read() -> Any:
            if last and tick_uniform(seed, salt, world.tick) < self.drawn["dropout"][name]:
                return last[0]
            value = read()
            last[:] = [value]
            return value

        component.read = dropping_read


def tick_uniform(seed: int, salt: int, tick: int) -> float:
    """A number in [0, 1) that depends only on the seed, a salt and the tick (the dropout coin)."""
    seq = np.random.SeedSequence([int(seed) % 2**32, STREAM, salt, int(tick)])
    return float(np.random.Generator(np.random.PCG64(seq)).random())


def light_direction(azimuth_deg: float, elevation_deg: float) -> list[float]:
    """Unit vector towards the light: ``azimuth`` about +z from +x, ``elevation`` above the horizon (degrees)."""
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    return [math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)]


def jitter_colour(rgba: Any, dh: float, ds: float, dv: float) -> list[float]:
    """An RGBA colour moved in HSV: hue by ``dh`` turns (wrapping), saturation and value by ``ds``/``dv`` (clamped
    to 0-1); alpha kept."""
    h, s, v = colorsys.rgb_to_hsv(*(float(c) for c in tuple(rgba)[:3]))
    r, g, b = colorsys.hsv_to_rgb((h + dh) % 1.0, min(1.0, max(0.0, s + ds)), min(1.0, max(0.0, v + dv)))
    return [r, g, b, float(tuple(rgba)[3])]
