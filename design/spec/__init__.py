"""The spec file: its pydantic schema and the admittance problem it declares.

May import: ``design.loop``, ``design.problem``, ``plant``."""
