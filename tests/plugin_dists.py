"""Fake third-party plugin distributions on disk, for the plugin-loading and fault-isolation tests.

A "distribution" here is what pip would leave in site-packages: a ``NAME-VERSION.dist-info`` folder with
``METADATA`` and ``entry_points.txt`` (group ``robokit``), next to the plugin module itself. Putting the folder on
``sys.path`` (or ``PYTHONPATH`` for a subprocess) makes ``importlib.metadata`` — and so robokit — see it.
"""

from __future__ import annotations

import itertools
import textwrap
from pathlib import Path

_serial = itertools.count()

FAULTY_SENSORS = '''
from robokit import hookimpl
from robokit.components import Sensor
from robokit.config import Schema


class FaultConfig(Schema):
    """``fail_at_read``: the read that raises (1 = the first)."""

    fail_at_read: int = 3


class FlakySetup(Sensor):
    """A sensor whose setup raises (a missing calibration file)."""

    reading_type = float

    def setup(self, ctx):
        super().setup(ctx)
        raise RuntimeError("calibration file missing")

    def read(self):
        return 0.0


class FlakyRead(Sensor):
    """A sensor that raises on its Nth read (a bus timeout)."""

    reading_type = float

    def setup(self, ctx):
        super().setup(ctx)
        self.reads = 0

    def read(self):
        self.reads += 1
        if self.reads >= self.config.fail_at_read:
            raise RuntimeError("sensor bus timeout")
        return float(self.reads)


@hookimpl
def robokit_register_sensors(register):
    register("flaky_setup", FlakySetup, FaultConfig)
    register("flaky_read", FlakyRead, FaultConfig)
'''

GOOD_SENSOR = '''
from robokit import hookimpl
from robokit.components import Sensor
from robokit.config import Schema


class ProbeConfig(Schema):
    """No options."""


class Probe(Sensor):
    """Reads the sim time in seconds (a third-party sensor that works)."""

    reading_type = float

    def read(self):
        return self.world.time


@hookimpl
def robokit_register_sensors(register):
    register("{type_name}", Probe, ProbeConfig)
'''

BROKEN_IMPORT = '''
import robokit_this_dependency_is_not_installed  # noqa: F401

from robokit import hookimpl


@hookimpl
def robokit_register_sensors(register):
    register("ghost", object, None)
'''

BAD_SIGNATURE = '''
from robokit import hookimpl


@hookimpl
def robokit_register_sensors(register, colour):
    """Asks for an argument the hook spec does not have."""
'''

UNKNOWN_HOOK = '''
from robokit import hookimpl


@hookimpl
def robokit_register_sensor(register):
    """A typo: the spec is robokit_register_sensors."""
'''

RAISING_RUN_START = '''
from robokit import hookimpl


@hookimpl
def robokit_run_start(simulation):
    raise RuntimeError("telemetry server unreachable")
'''


def make_dist(root: Path, name: str, version: str, source: str, *, entry_name: str = "main",
              **fmt: str) -> str:
    """Write a distribution with one plugin module into ``root``; return the module's (unique) name."""
    module = f"{name.replace('-', '_')}_{next(_serial)}"
    root.mkdir(parents=True, exist_ok=True)
    (root / f"{module}.py").write_text(textwrap.dedent(source).replace("{type_name}", fmt.get("type_name", "")))
    info = root / f"{name.replace('-', '_')}-{version}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")
    (info / "entry_points.txt").write_text(f"[robokit]\n{entry_name} = {module}\n")
    return module

BROKEN_REPORTER = '''
from robokit import hookimpl
from robokit.components import Reporter
from robokit.config import Schema


class GrumpyConfig(Schema):
    """No options."""


class Grumpy(Reporter):
    """A reporter whose constructor raises."""

    def __init__(self, name, config):
        raise RuntimeError("no credentials")


@hookimpl
def robokit_register_reporters(register):
    register("grumpy", Grumpy, GrumpyConfig)
'''

HALF_REGISTERING = '''
from robokit import hookimpl
from robokit.components import Sensor
from robokit.config import Schema


class Cfg(Schema):
    """No options."""


class First(Sensor):
    """Registered before the hook raised."""

    reading_type = float


@hookimpl
def robokit_register_sensors(register):
    register("first_half", First, Cfg)
    raise KeyError("second_half")
'''
