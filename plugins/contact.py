"""``contact`` sensor (lesson 04): contacts between a named body (or one of its links) and others.

``other`` names the body to watch for (default: anything but the body itself); ``ignore`` lists bodies whose
contacts do not count ("anything but the floor": ``ignore = ["plane"]``); ``link`` and ``other_link`` narrow
either side to one link. The reading (:class:`~robokit.msgs.arm.ContactState`) gives whether there is
contact, the number of contact points, the total normal force (N) and the names of the bodies touched.
"""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import Field

from robokit import hookimpl
from robokit.components import Sensor, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.msgs.arm import ContactState


class ContactConfig(Schema):
    """``[sensors.NAME]`` with ``type = "contact"``."""

    body: str = Field(description="body whose contacts are reported")
    link: str | None = Field(None, description="only this link of body (default: every link)")
    other: str | None = Field(None, description="only contacts with this body (default: any other body)")
    other_link: str | None = Field(None, description="only this link of other")
    ignore: tuple[str, ...] = Field((), description="bodies whose contacts do not count (e.g. the floor)")
    min_force: float = Field(0.0, ge=0, description="ignore contact points with less normal force, N")


class ContactSensor(Sensor):
    """Contacts of a body or link with a named body or anything: in contact, points, normal force, names."""

    reading_type = ContactState
    example: ClassVar[dict[str, Any] | None] = {
        "config": {"body": "box", "other": "plane"},
        "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                   "box": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, "position": [0, 0, 0.06]}},
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg: ContactConfig = self.config
        self.body = self._body(cfg.body, "body")
        self.other = self._body(cfg.other, "other") if cfg.other is not None else None
        self.link = self._link(cfg.body, cfg.link, "link")
        if cfg.other_link is not None and cfg.other is None:
            raise ConfigError("'other_link' needs 'other' (the body the link belongs to)", key="other_link")
        self.other_link = self._link(cfg.other, cfg.other_link, "other_link") if cfg.other else None
        if cfg.other is not None and cfg.ignore:
            raise ConfigError("'ignore' is for contacts with anything ('other' not set); with 'other' only that body "
                              "counts", key="ignore")
        self.ignored = {self.body} | {self._body(name, f"ignore[{i}]") for i, name in enumerate(cfg.ignore)}

    def _body(self, name: str, key: str) -> int:
        return self.ctx.body(name, key=key)

    def _link(self, body: str, link: str | None, key: str) -> int | None:
        return None if link is None else self.ctx.link(body, link, key=key)

    def read(self) -> ContactState:
        """Contact points now (from the last physics step)."""
        points = [cp for cp in self.world.contacts(self.body, self.other, link=self.link, other_link=self.other_link)
                  if cp.other not in self.ignored and cp.normal_force >= self.config.min_force]
        names = {self.world.body_name(cp.other) or f"body{cp.other}" for cp in points}
        return ContactState(in_contact=bool(points), points=len(points),
                            normal_force=float(sum(cp.normal_force for cp in points)), others=tuple(sorted(names)))


@hookimpl
def robokit_register_sensors(register):  # type: ignore[no-untyped-def]
    register("contact", ContactSensor, ContactConfig)
