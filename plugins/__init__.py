"""robokit's built-in plugins, one device per module. Shipped as ``robokit_plugins``; each module is registered
through the ``robokit`` entry-point group, exactly as a third-party plugin is."""
