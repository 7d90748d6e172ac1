"""Plugin loading: a fresh pluggy manager per simulation, entry points of the ``robokit`` group, type registries.

Nothing is loaded at import time and there is no module-level manager: call :func:`load_plugins`.
"""

from __future__ import annotations

import importlib.metadata as md
import inspect
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import pluggy

from robokit import hookspecs
from robokit.errors import LookupNameError, PluginError, UserError

ENTRY_POINT_GROUP = "robokit"
KINDS = ("sensor", "actuator", "behaviour", "reporter", "task")
_HOOK_OF_KIND = {
    "sensor": "robokit_register_sensors",
    "actuator": "robokit_register_actuators",
    "behaviour": "robokit_register_behaviours",
    "reporter": "robokit_register_reporters",
    "task": "robokit_register_tasks",
}


class PluginLoadWarning(UserWarning):
    """A plugin distribution could not be loaded; the others still are."""


@dataclass(frozen=True)
class PluginType:
    """One registered type: its kind, config name, class, schema and where it came from."""

    kind: str
    name: str
    cls: type
    schema: type | None
    distribution: str
    version: str
    plugin: str

    @property
    def description(self) -> str:
        """First line of the class docstring."""
        doc = inspect.getdoc(self.cls) or ""
        return doc.splitlines()[0] if doc else ""

    @property
    def origin(self) -> str:
        """``"distribution version"``, for messages."""
        return f"{self.distribution} {self.version}".strip()


@dataclass
class Plugins:
    """A loaded plugin manager and the types its plugins registered, by kind then name."""

    pm: pluggy.PluginManager
    types: dict[str, dict[str, PluginType]] = field(default_factory=lambda: {k: {} for k in KINDS})
    broken: dict[str, str] = field(default_factory=dict)
    """Distributions (or plugins) that failed to load, with the reason."""

    def get(self, kind: str, name: str, *, where: str = "") -> PluginType:
        """The registered type of a kind by name.

        Raises:
            UserError: Unknown type; the message lists the valid ones and any plugin that failed to load.
        """
        try:
            return self.types[kind][name]
        except KeyError:
            err = LookupNameError(f"{kind} type", name, self.types[kind], where=where)
            if self.broken:
                notes = "; ".join(f"{dist} failed to load: {why}" for dist, why in self.broken.items())
                raise UserError(f"{err} (note: {notes})") from None
            raise err from None

    def all_types(self) -> list[PluginType]:
        """Every registered type, sorted by kind then name."""
        return [t for kind in KINDS for _, t in sorted(self.types[kind].items())]

    @property
    def hook(self) -> Any:
        """The manager's hook relay, for lifecycle calls."""
        return self.pm.hook

    def call(self, hook_name: str, **kwargs: Any) -> None:
        """Call a lifecycle hook implementation by implementation.

        Raises:
            PluginError: An implementation raised; the message names the plugin (``distribution:entry point``).
        """
        for impl in reversed(getattr(self.pm.hook, hook_name).get_hookimpls()):
            try:
                impl.function(**{k: v for k, v in kwargs.items() if k in impl.argnames})
            except Exception as exc:
                raise PluginError(f"plugin {impl.plugin_name} raised in {hook_name}: {type(exc).__name__}: {exc}",
                                  type_name=hook_name, distribution=impl.plugin_name) from exc


def _dist_label(dist: md.Distribution | None) -> tuple[str, str]:
    if dist is None:
        return ("<local>", "")
    return (dist.metadata["Name"] or "<unknown>", dist.version or "")


def _entry_points() -> list[md.EntryPoint]:
    eps = md.entry_points(group=ENTRY_POINT_GROUP)
    seen: dict[tuple[str, str], md.EntryPoint] = {}
    for ep in eps:  # the same distribution can be visible twice (e.g. editable + path entry)
        seen.setdefault((ep.name, ep.value), ep)
    return sorted(seen.values(), key=lambda e: (e.dist.metadata["Name"] if e.dist else "", e.name))


def _register_checked(pm: pluggy.PluginManager, plugin: object, name: str) -> str | None:
    """Register one plugin object; return a reason if it was rejected (bad hook signature or unknown hook)."""
    try:
        pm.register(plugin, name=name)
    except pluggy.PluginValidationError as exc:
        return "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())
    except ValueError as exc:
        return str(exc).splitlines()[0]
    unknown = [hc.name for hc in (pm.get_hookcallers(plugin) or []) if not hc.has_spec()]
    if unknown:
        pm.unregister(plugin)
        return f"implements unknown hook(s) {', '.join(unknown)}"
    return None


def load_plugins(extra: Iterable[object] = (), *, entry_points: bool = True) -> Plugins:
    """Build a fresh plugin manager, load the ``robokit`` entry points and ``extra`` plugin objects, and collect
    every registered type.

    A distribution whose entry point fails to import, or whose hooks do not match their specs, is skipped with a
    :class:`PluginLoadWarning` naming it; the others still load.

    Raises:
        UserError: Two plugins register the same type name for the same kind (the message names both).
    """
    _import_pybullet_quietly()
    pm = pluggy.PluginManager("robokit")
    pm.add_hookspecs(hookspecs)
    plugins = Plugins(pm=pm)
    origins: dict[str, tuple[str, str]] = {}
    if entry_points:
        for ep in _entry_points():
            dist, version = _dist_label(ep.dist)
            label = f"{dist} (entry point {ep.name!r})"
            try:
                obj = ep.load()
            except Exception as exc:  # noqa: BLE001 - a broken third-party package must not stop the others
                _reject(plugins, label, f"import failed: {type(exc).__name__}: {exc}")
                continue
            name = f"{dist}:{ep.name}"
            if pm.is_registered(obj):
                continue
            reason = _register_checked(pm, obj, name)
            if reason:
                _reject(plugins, label, reason)
                continue
            origins[name] = (dist, version)
    for i, obj in enumerate(extra):
        name = getattr(obj, "__name__", None) or f"extra-{i}"
        reason = _register_checked(pm, obj, name)
        if reason:
            _reject(plugins, name, reason)
            continue
        origins[name] = ("<local>", "") if not hasattr(obj, "__robokit_dist__") else obj.__robokit_dist__
    pm.check_pending()
    for kind in KINDS:
        _collect(plugins, kind, origins)
    return plugins


def _reject(plugins: Plugins, label: str, reason: str) -> None:
    plugins.broken[label] = reason
    warnings.warn(f"robokit plugin {label} not loaded: {reason}", PluginLoadWarning, stacklevel=3)


def _collect(plugins: Plugins, kind: str, origins: dict[str, tuple[str, str]]) -> None:
    hook = getattr(plugins.pm.hook, _HOOK_OF_KIND[kind])
    for impl in reversed(hook.get_hookimpls()):  # registration order
        dist, version = origins.get(impl.plugin_name, ("<local>", ""))

        def register(type_name: str, cls: type, schema: type | None = None, *, _p: str = impl.plugin_name,
                     _d: str = dist, _v: str = version) -> None:
            existing = plugins.types[kind].get(type_name)
            if existing is not None:
                raise UserError(
                    f"{kind} type {type_name!r} is registered twice: by {existing.origin} "
                    f"({existing.plugin}) and by {_d} {_v} ({_p})".replace("  ", " ")
                )
            plugins.types[kind][type_name] = PluginType(kind, type_name, cls, schema, _d, _v, _p)

        before = set(plugins.types[kind])
        try:
            impl.function(register=register)
        except UserError:
            raise
        except Exception as exc:  # noqa: BLE001 - isolate a faulty plugin
            for partial in set(plugins.types[kind]) - before:
                del plugins.types[kind][partial]
            _reject(plugins, f"{dist} ({impl.plugin_name})", f"{_HOOK_OF_KIND[kind]} raised {exc!r}")


def _import_pybullet_quietly() -> None:
    """Import pybullet once with its C-level banner silenced (plugin modules import it as they load)."""
    from robokit._quiet import quiet_stdout

    with quiet_stdout():
        try:
            import pybullet  # noqa: F401
        except ImportError:  # let the plugin that needs it report the problem
            pass
