"""Velocity loops and their numbers: open loops, margins (exact and fast paths), payload sweeps,
the thesis reproduction.

May import: ``design.problem``, ``design.parallel``, ``plant``.
"""
