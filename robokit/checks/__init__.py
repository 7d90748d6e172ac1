"""Tools for plugin authors and for robokit's own tests: conformance checks for sensor, actuator and behaviour types,
the plugin linter, scripted (physics-free) runs, the pytest plugin and the docs' sample-output checker.

Everything here is reached through :mod:`robokit.testing`, the versioned door. May import every room below the CLI
(``core``, ``config``, ``plugin_api``, ``report``, ``process``); nothing else imports this room but
``robokit.testing`` and the CLI.
"""
