"""Experiments: excitation design and the simulator that records a plant, planned for what the estimators need.
May import: ``plant.estimate``, ``plant.data``, ``plant.physics``, ``plant.host``, ``plant.errors``,
``plant.grid``, ``plant.arguments``."""
