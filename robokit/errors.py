"""Errors meant for people.

A :class:`UserError` is something the user can fix (a bad config, an unknown joint, an unreachable target). The
CLI prints it as one line and exits with code 2; a traceback is kept for bugs only.
"""

from __future__ import annotations

from collections.abc import Iterable


class UserError(Exception):
    """An error caused by input the user controls; printed as one line, never with a traceback."""


class ConfigError(UserError):
    """A configuration problem at a known place.

    Attributes:
        file: The config file (or ``"<dict>"`` for configs built in code).
        key: Dotted key path inside the file, e.g. ``"sensors.cam.width"``.
        message: What was expected and what was found.
    """

    def __init__(self, message: str, *, key: str = "", file: str = "") -> None:
        self.file = file
        self.key = key
        self.message = message
        super().__init__(self._render())

    def _render(self) -> str:
        where = ": ".join(part for part in (self.file, self.key) if part)
        return f"{where}: {self.message}" if where else self.message

    def within(self, prefix: str = "", file: str = "") -> ConfigError:
        """Return a copy placed under a key prefix and/or in a file (keeps what is already set)."""
        key = ".".join(part for part in (prefix, self.key) if part)
        return ConfigError(self.message, key=key, file=self.file or file)


class LookupNameError(UserError):
    """A name (body, joint, link, plugin type...) that does not exist; the message lists the valid ones."""

    def __init__(self, kind: str, name: str, valid: Iterable[str], *, where: str = "") -> None:
        valid = sorted(valid)
        self.kind, self.name, self.valid = kind, name, valid
        hint = did_you_mean(name, valid)
        listed = ", ".join(valid) if len(valid) <= 30 else ", ".join(valid[:30]) + ", ..."
        place = f" in {where}" if where else ""
        super().__init__(f"unknown {kind} {name!r}{place}{hint}; valid: {listed or '(none)'}")


class PluginError(Exception):
    """A plugin misbehaved (raised during setup/read, or broke the plugin contract).

    Attributes:
        type_name: The plugin type involved, e.g. ``"camera"``.
        distribution: The distribution that provides it, e.g. ``"robokit 0.1.0"``.
    """

    def __init__(self, message: str, *, type_name: str = "", distribution: str = "") -> None:
        self.type_name = type_name
        self.distribution = distribution
        super().__init__(message)


class Interrupted(KeyboardInterrupt):
    """Raised by robokit's own signal handler (Ctrl-C, SIGTERM) or its wall-clock watchdog, never by plugins.

    A plain ``KeyboardInterrupt`` or ``SystemExit`` raised by plugin code is a plugin fault, not a request to stop.

    Attributes:
        reason: ``"SIGINT"``, ``"SIGTERM"`` or ``"max_wall_time"``.
    """

    def __init__(self, reason: str = "SIGINT") -> None:
        self.reason = reason
        super().__init__(reason)


def plugin_fault(exc: BaseException) -> str:
    """What a plugin raised and where, on one line: ``"TypeError: message (at path/file.py:42)"``."""
    from robokit.process.crash import describe, where_raised

    where = where_raised(exc)
    return describe(exc) + (f" (at {where})" if where else "")


def did_you_mean(name: str, candidates: Iterable[str]) -> str:
    """Return ``" (did you mean 'x'?)"`` for the closest candidate, or ``""``."""
    import difflib  # only when a name is wrong: every command imports this module

    close = difflib.get_close_matches(name, list(candidates), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""
