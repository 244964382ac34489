"""Imitation of the boustrophedon expert with ppo_gail's observation: ``bc`` (behaviour cloning) and
``dagger`` (DAgger), trained by ``python -m cabinbench.train --baseline bc|dagger`` (``training``; settings in
``config.ImitationConfig``; the expert and how it is asked in ``expert``) and run as ``--baseline bc|dagger``
(``policy``)."""
