"""The built-in layouts, installed as the data package ``cabinbench.layouts.builtin``."""
