"""Control design for the exoskeleton gantry: loops, margins, synthesis, sweeps, reports, CLI.

May import: ``plant`` (the version, on first use)."""

__all__ = ["__version__"]


def __getattr__(name: str):
    """``__version__`` on first use: importing ``design`` (as the command line does first) stays light."""
    if name == "__version__":
        from plant import __version__

        return __version__
    raise AttributeError(f"module 'design' has no attribute {name!r}")
