"""The admittance controller (m_v, b_v) for mouse following: its model, synthesis and verification.

May import: ``design.synth``, ``design.loop``, ``design.problem``, ``design.parallel``, ``plant``."""
