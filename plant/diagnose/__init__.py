"""Diagnosis: which effect the model misses, by model search on the fits, and its shared evidence vocabulary.
May import: ``plant.identify``, ``plant.experiment``, ``plant.estimate``, ``plant.data``, ``plant.physics``,
``plant.host``, ``plant.errors``, ``plant.grid``, ``plant.arguments``, ``plant.story``."""
