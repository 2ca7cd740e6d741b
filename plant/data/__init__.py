"""Measurements: recording types (stepped sine, time domain, frequency response), their readers and writers.
May import: ``plant.host`` and the base modules (``plant.errors``, ``plant.grid``)."""
