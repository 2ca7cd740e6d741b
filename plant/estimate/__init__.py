"""Estimation of a frequency response from a recording: lock-in per block, FRF of any excitation.
May import: ``plant.data``, ``plant.physics``, ``plant.host``, ``plant.errors``, ``plant.grid``, ``plant.arguments``."""
