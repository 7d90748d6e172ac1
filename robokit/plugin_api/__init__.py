"""How plugins reach robokit: the hook specifications, the plugin manager and the registries of types it fills
(``plugins``), and the entry points of installed distributions (``entry_points``: asked of importlib.metadata,
remembered between runs).

May import: ``robokit.errors``, ``robokit.process`` and ``robokit.config``. Nothing above them: the core uses the
plugin API, not the other way round.
"""
