"""PI synthesis: convex-concave scan and exact formulations, independent verification, gain
schedules, design from measured responses.

May import: ``design.loop``, ``design.problem``, ``design.parallel``, ``plant``.
"""
