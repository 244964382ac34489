"""Layout kinds, one module each: ``cabin``, ``grid``, ``polygons``, ``occupancy``
(:data:`cabinbench.layouts.load.LAYOUT_KINDS` registers them)."""
