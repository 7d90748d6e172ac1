"""Physics engines behind the World. May import: robokit.errors, robokit.extras, robokit.core.world."""
