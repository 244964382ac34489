"""The generated paper: the reproduction report beside ``python -m cabinbench.paper``
(:mod:`cabinbench.commands.paper`)."""
