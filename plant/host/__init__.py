"""Host infrastructure, no physics: Ctrl-C and SIGTERM handling, text decoding, atomic file writes, malloc's
thresholds.
May import: ``plant.errors``."""
