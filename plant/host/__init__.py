"""Host infrastructure, no physics: Ctrl-C and SIGTERM handling, text decoding, atomic file writes.
May import: ``plant.errors``."""
