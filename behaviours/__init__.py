"""robokit's built-in behaviours, one machine per module. Shipped as ``robokit_behaviours``; each module is
registered through the ``robokit`` entry-point group."""
