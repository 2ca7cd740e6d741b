"""Measurements: the recording types (``recordings``), ``read_measurement`` (``read``) over the stepped-sine and
time-domain readers and their one CSV table reader, the writers, and the estimated ``MeasuredResponse``.
May import: ``plant.bode``, ``plant.host``, ``plant.errors``, ``plant.grid``, ``plant.arguments``."""
