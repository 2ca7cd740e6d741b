"""Experiments: excitation design and the simulator that records a plant.
May import: ``plant.data``, ``plant.physics``, ``plant.host`` and the base modules."""
