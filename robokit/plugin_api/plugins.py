"""Plugin loading: a fresh pluggy manager per simulation, entry points of the ``robokit`` group, type registries.

Nothing is loaded at import time and there is no module-level manager: call :func:`load_plugins`.
"""

from __future__ import annotations

import inspect
import warnings
from collections.abc import Iterable, Iterator, MutableMapping
from typing import Any, NamedTuple

import pluggy

from robokit.errors import Interrupted, LookupNameError, PluginError, UserError, plugin_fault
from robokit.plugin_api import hookspecs
from robokit.plugin_api.entry_points import EntryPoint, entry_points

ENTRY_POINT_GROUP = "robokit"
BUILTIN = "robokit"
"""The distribution of the built-in types: they keep their names when a plugin registers the same one."""
INDEX_GROUP = "robokit.types"
"""Optional entry-point group naming which module registers which type: ``"KIND.TYPE" = "module"``. A module
listed there is imported only when a config (or a lookup) needs one of its types."""
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


class PluginType(NamedTuple):
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

    @property
    def qualified(self) -> str:
        """``"distribution:type"``: the name a config may always use, whatever else is installed."""
        return f"{self.distribution}:{self.name}"

    def provided(self) -> str:
        """`` (sensor type 'x' from dist 1.0)`` for messages about a section of a third-party type; "" for
        robokit's own types."""
        if self.distribution in (BUILTIN, "<local>"):  # robokit's own, or registered in code: nothing to name
            return ""
        return f" ({self.kind} type {self.name!r} from {self.origin})"


def normalized(distribution: str) -> str:
    """A distribution name as pip compares them: lower case, runs of ``-``, ``_`` and ``.`` as one ``-``."""
    out: list[str] = []
    dash = False
    for ch in distribution.lower():
        if ch in "-_.":
            dash = True
            continue
        if dash and out:
            out.append("-")
        dash = False
        out.append(ch)
    return "".join(out)


class KindTypes(MutableMapping[str, PluginType]):
    """The registered types of one kind, by name.

    On lazily loaded plugins (the default, see :func:`load_plugins`), looking a name up imports only the plugin
    module that provides it; iterating or counting loads every plugin first.
    """

    def __init__(self, kind: str, owner: Plugins) -> None:
        self.kind = kind
        self._owner = owner
        self.data: dict[str, PluginType] = {}

    def __getitem__(self, name: str) -> PluginType:
        if name not in self.data:
            self._owner.want(self.kind, name)
        return self.data[name]

    def __contains__(self, name: object) -> bool:
        if isinstance(name, str) and name not in self.data:
            self._owner.want(self.kind, name)
        return name in self.data

    def __iter__(self) -> Iterator[str]:
        self._owner.complete()
        return iter(self.data)

    def __len__(self) -> int:
        self._owner.complete()
        return len(self.data)

    def __setitem__(self, name: str, value: PluginType) -> None:
        self.data[name] = value

    def __delitem__(self, name: str) -> None:
        del self.data[name]


class Plugins:
    """A loaded plugin manager and the types its plugins registered, by kind then name.

    ``broken`` holds the distributions (or plugins) that failed to load, with the reason.
    """

    def __init__(self, pm: pluggy.PluginManager, broken: dict[str, str] | None = None) -> None:
        self.pm = pm
        self.broken: dict[str, str] = {} if broken is None else broken
        self.types = {k: KindTypes(k, self) for k in KINDS}
        self._pending: dict[str, EntryPoint] = {}  # entry points not imported yet, by module
        self._index: dict[tuple[str, str], str] = {}  # (kind, type name) -> module that registers it
        self._origins: dict[str, tuple[str, str]] = {}
        self._collected: set[tuple[str, str]] = set()  # (kind, plugin name) whose registration hook was called
        self.qualified: dict[str, dict[tuple[str, str], PluginType]] = {k: {} for k in KINDS}
        """Every registered type by kind, then (normalised distribution name, type name)."""
        self.ambiguous: dict[str, dict[str, list[PluginType]]] = {k: {} for k in KINDS}
        """Bare type names registered by two or more third-party distributions: a config must say which."""
        self.shadowed: dict[str, dict[str, list[PluginType]]] = {k: {} for k in KINDS}
        """Third-party types whose bare name is a built-in's: reachable as ``distribution:type`` only."""

    def want(self, kind: str, name: str) -> None:
        """Make sure the type ``kind``/``name`` is loaded if any plugin provides it (imports its module only,
        when the ``robokit.types`` index names it; every plugin otherwise)."""
        module = self._index.get((kind, name))
        if module is not None and module in self._pending:
            _load_entry_point(self, self._pending.pop(module))
            if name in self.types[kind].data:
                return
        self.complete()

    def complete(self) -> None:
        """Import every plugin not imported yet (what listing all types needs)."""
        while self._pending:
            _load_entry_point(self, self._pending.pop(next(iter(self._pending))))
        self._index.clear()

    def get(self, kind: str, name: str, *, where: str = "") -> PluginType:
        """The registered type of a kind by name.

        Raises:
            UserError: Unknown type; the message lists the valid ones and any plugin that failed to load.
        """
        dist, sep, bare = name.rpartition(":")
        if sep:
            return self._qualified(kind, dist, bare, where)
        try:
            return self.types[kind][name]
        except KeyError:
            clash = self.ambiguous[kind].get(name)
            if clash:
                raise UserError(self.ambiguity(kind, name)) from None
            err = LookupNameError(f"{kind} type", name, self.types[kind], where=where)
            if self.broken:
                notes = "; ".join(f"{dist} failed to load: {why}" for dist, why in self.broken.items())
                raise UserError(f"{err} (note: {notes})") from None
            raise err from None

    def ambiguity(self, kind: str, name: str) -> str:
        """One line: which distributions register ``name`` and how a config names each."""
        clash = self.ambiguous[kind][name]
        who = " and ".join(t.origin for t in clash)
        ways = " or ".join(repr(t.qualified) for t in clash)
        return f"{kind} type {name!r} is ambiguous: it is registered by {who}; write {ways}"

    def _qualified(self, kind: str, dist: str, name: str, where: str) -> PluginType:
        """A ``distribution:type`` name (the distribution as pip spells it, any case, ``-``/``_`` alike)."""
        self.complete()
        found = self.qualified[kind].get((normalized(dist), name))
        if found is not None:
            return found
        providers = sorted(t.qualified for (_, n), t in self.qualified[kind].items() if n == name)
        if providers:
            raise UserError(f"{where + ': ' if where else ''}no {kind} type {name!r} in distribution {dist!r}; "
                            f"{name!r} comes from: {', '.join(providers)}")
        raise LookupNameError(f"{kind} type", name, self.types[kind], where=where)

    def all_types(self) -> list[PluginType]:
        """Every registered type, sorted by kind then name (every provider of an ambiguous name)."""
        out: list[PluginType] = []
        for kind in KINDS:
            self.complete()
            named = [(n, t.distribution, t) for n, t in self.types[kind].data.items()]
            named += [(n, t.distribution, t) for n, clash in self.ambiguous[kind].items() for t in clash]
            named += [(n, t.distribution, t) for n, others in self.shadowed[kind].items() for t in others]
            out += [t for _, _, t in sorted(named, key=lambda x: (x[0], x[1]))]
        return out

    def listed_name(self, t: PluginType) -> str:
        """The name a config uses for ``t``: its bare name when that leads to it, else ``distribution:type``."""
        return t.name if self.types[t.kind].data.get(t.name) is t else t.qualified

    def clashes(self) -> list[str]:
        """One line per type name two distributions register, naming both owners and how to reach each."""
        self.complete()
        out = []
        for kind in KINDS:
            for name, others in sorted(self.shadowed[kind].items()):
                mine = self.types[kind].data[name]
                out.append(f"{kind} type {name!r}: {mine.origin} (the bare name) and "
                           + " and ".join(f"{t.origin} (as {t.qualified!r})" for t in others))
            for name, clash in sorted(self.ambiguous[kind].items()):
                out.append(f"{kind} type {name!r}: " + " and ".join(f"{t.origin} (as {t.qualified!r})" for t in clash))
        return out

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
            except Interrupted:
                raise
            except BaseException as exc:  # SystemExit and KeyboardInterrupt from a plugin are plugin faults too
                raise PluginError(f"plugin {impl.plugin_name} raised in {hook_name}: {plugin_fault(exc)}",
                                  type_name=hook_name, distribution=impl.plugin_name) from exc


def _entry_points() -> tuple[list[EntryPoint], dict[tuple[str, str], str] | None]:
    """The ``robokit`` entry points (sorted by distribution, then name) and the ``robokit.types`` index.

    The index maps ``(kind, type name)`` to the module that registers it (entry point ``"KIND.TYPE" = "module"``).
    It is None when two entries claim one type (a full load then reports the clash).
    """
    every = entry_points((ENTRY_POINT_GROUP, INDEX_GROUP))
    seen: dict[tuple[str, str], EntryPoint] = {}
    for ep in every:  # a distribution can be visible twice (editable + path)
        if ep.group == ENTRY_POINT_GROUP:
            seen.setdefault((ep.name, ep.value), ep)
    eps = sorted(seen.values(), key=lambda e: (e.distribution, e.name))
    index: dict[tuple[str, str], str] | None = {}
    for ep in (e for e in every if e.group == INDEX_GROUP):
        kind, _, name = ep.name.partition(".")
        if index is not None and index.setdefault((kind, name), ep.value) != ep.value:
            index = None
    return eps, index


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


def load_plugins(extra: Iterable[object] = (), *, entry_points: bool = True, lazy: bool = True) -> Plugins:
    """Build a fresh plugin manager, load the ``robokit`` entry points and ``extra`` plugin objects, and collect
    every registered type.

    With ``lazy`` (the default) and every entry point's module named in the ``robokit.types`` index (which type
    each module registers), a module is imported only when one of its types is looked up: a config that uses no
    camera never imports OpenCV. Listing the types imports them all. An entry point missing from the index (a
    third-party package that does not declare its types, or one that only implements lifecycle hooks) makes the
    load eager, as does ``lazy=False``: everything is imported now.

    A distribution whose entry point fails to import, or whose hooks do not match their specs, is skipped with a
    :class:`PluginLoadWarning` naming it; the others still load.

    Two distributions registering the same type name for the same kind: every type is always reachable as
    ``distribution:type``; robokit's built-in keeps its bare name, and between two other distributions the bare
    name becomes ambiguous (a config that uses it gets a one-line error listing both). Nothing depends on the
    order the distributions load in; a :class:`PluginLoadWarning` names a type shadowed by a built-in.
    """
    _import_pybullet_quietly()
    pm = pluggy.PluginManager("robokit")
    pm.add_hookspecs(hookspecs)
    plugins = Plugins(pm=pm)
    if entry_points:
        eps, index = _entry_points()
        lazy = lazy and index is not None and all(ep.value in index.values() for ep in eps)
        for ep in eps:
            if not lazy:
                _load_entry_point(plugins, ep, collect=False)
            elif ep.value not in plugins._pending:
                plugins._pending[ep.value] = ep
        if lazy:
            plugins._index = dict(index or {})
    for i, obj in enumerate(extra):
        name = getattr(obj, "__name__", None) or f"extra-{i}"
        origin = ("<local>", "") if not hasattr(obj, "__robokit_dist__") else obj.__robokit_dist__
        _register(plugins, obj, name, name, origin, collect=False)
    pm.check_pending()
    for kind in KINDS:
        _collect(plugins, kind, plugins._origins)
    if any((k, n) in plugins._index for k in KINDS for n in plugins.types[k].data):
        # an extra plugin claims an indexed type: load eagerly, in the usual order, so the clash is named
        return load_plugins(extra, entry_points=entry_points, lazy=False)
    return plugins


def _load_entry_point(plugins: Plugins, ep: EntryPoint, *, collect: bool = True) -> None:
    """Import one entry point, register it and collect the types it registers (or record why not)."""
    dist, version = ep.distribution, ep.version
    label = f"{dist} (entry point {ep.name!r})"
    try:
        obj = ep.load()
    except Exception as exc:  # noqa: BLE001 - a broken third-party package must not stop the others
        _reject(plugins, label, f"import failed: {type(exc).__name__}: {exc}")
        return
    if plugins.pm.is_registered(obj):
        return
    _register(plugins, obj, f"{dist}:{ep.name}", label, (dist, version), collect=collect)


def _register(plugins: Plugins, obj: object, name: str, label: str, origin: tuple[str, str], *,
              collect: bool) -> None:
    """Register a plugin object; with ``collect``, call its registration hooks now (a lazy load)."""
    reason = _register_checked(plugins.pm, obj, name)
    if reason:
        _reject(plugins, label, reason)
        return
    plugins._origins[name] = origin
    if collect:
        for kind in KINDS:
            _collect(plugins, kind, plugins._origins, only=name)


def _reject(plugins: Plugins, label: str, reason: str) -> None:
    plugins.broken[label] = reason
    warnings.warn(f"robokit plugin {label} not loaded: {reason}", PluginLoadWarning, stacklevel=3)


def _collect(plugins: Plugins, kind: str, origins: dict[str, tuple[str, str]], only: str | None = None) -> None:
    """Call the registration hook of one kind on every plugin not asked yet (or on the one named ``only``); the
    types they register join ``plugins.types``."""
    hook = getattr(plugins.pm.hook, _HOOK_OF_KIND[kind])
    types = plugins.types[kind].data
    for impl in reversed(hook.get_hookimpls()):  # pluggy's call order (the last registered first)
        if (kind, impl.plugin_name) in plugins._collected or (only is not None and impl.plugin_name != only):
            continue
        plugins._collected.add((kind, impl.plugin_name))
        dist, version = origins.get(impl.plugin_name, ("<local>", ""))

        def register(type_name: str, cls: type, schema: type | None = None, *, _p: str = impl.plugin_name,
                     _d: str = dist, _v: str = version) -> None:
            if not isinstance(type_name, str) or not type_name or ":" in type_name:
                bare = str(type_name).rpartition(":")[2]
                _reject(plugins, f"{_d} ({_p})", f"{kind} type {type_name!r} not registered: a type name has no "
                        f"distribution part: register {bare!r}, and configs reach it as '{_d}:{bare}'")
                return
            new = PluginType(kind, type_name, cls, schema, _d, _v, _p)
            _add(plugins, new)

        before = set(types)
        try:
            impl.function(register=register)
        except UserError:
            raise
        except Exception as exc:  # noqa: BLE001 - isolate a faulty plugin
            for partial in set(types) - before:
                del types[partial]
            _reject(plugins, f"{dist} ({impl.plugin_name})", f"{_HOOK_OF_KIND[kind]} raised {exc!r}")


def _add(plugins: Plugins, new: PluginType) -> None:
    """Register a type under ``distribution:type`` always, and under its bare name unless that clashes.

    A clash is never settled by load order: robokit's built-in types keep their bare names (the other type is
    reachable as ``distribution:type`` only); between two other distributions the bare name becomes ambiguous
    (using it is a config error listing both). ``robokit plugins`` lists every owner, and the clash once
    (:meth:`Plugins.clashes`); nothing is printed on other commands.
    """
    kind, name = new.kind, new.name
    plugins.qualified[kind].setdefault((normalized(new.distribution), name), new)
    types, clash = plugins.types[kind].data, plugins.ambiguous[kind]
    if name in clash:
        if all(t.distribution != new.distribution for t in clash[name]):
            clash[name].append(new)
        return
    existing = types.get(name)
    if existing is None:
        types[name] = new
        return
    if existing.distribution == new.distribution:
        _reject(plugins, f"{new.origin} ({kind} type {name!r})", f"registered twice (by {existing.plugin} and "
                f"{new.plugin}); the first is kept")
        return
    builtin = [t for t in (existing, new) if t.distribution == BUILTIN]
    if builtin:
        other = new if builtin[0] is existing else existing
        types[name] = builtin[0]
        plugins.shadowed[kind].setdefault(name, []).append(other)
        return
    del types[name]  # no warning: an ambiguous name is an error only where a config uses it
    clash[name] = sorted([existing, new], key=lambda t: normalized(t.distribution))


def _import_pybullet_quietly() -> None:
    """Import pybullet once with its C-level banner silenced (plugin modules import it as they load)."""
    from robokit.process.quiet import quiet_stdout

    with quiet_stdout():
        try:
            import pybullet  # noqa: F401
        except ImportError:  # let the plugin that needs it report the problem
            pass
