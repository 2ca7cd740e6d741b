"""Identification: the frequency-domain, time-domain (inverse model) and rational fits, residuals, report text.
May import: ``plant.experiment``, ``plant.estimate``, ``plant.data``, ``plant.physics``, ``plant.host``,
``plant.errors``, ``plant.grid``, ``plant.arguments``, ``plant.story``."""
