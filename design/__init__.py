"""Control design for the exoskeleton gantry: loops, margins, synthesis, sweeps, reports, CLI."""

from plant import __version__

__all__ = ["__version__"]
