"""Errors of the gantry tool: every bad input raises a subclass of ``GantryError``.

``GantryError`` is a ``ValueError`` so callers that already catch ``ValueError``
keep working; the command line turns it into one line on stderr and exit status 2.

May import: nothing of the tool.
"""


class GantryError(ValueError):
    """Bad input to the tool; the message names what is wrong and where."""


class ParameterError(GantryError):
    """A physical parameter is non-physical (negative mass, NaN, out of bounds)."""


class GridError(GantryError):
    """A frequency grid is empty, non-finite or not strictly increasing."""


class EffectError(GantryError):
    """An unknown effect name, or an effect used where it does not apply."""


class DataError(GantryError):
    """A recording cannot be read or does not support the requested estimate."""


class SpecError(GantryError):
    """A spec file is invalid; the message names the key path."""


class ArgumentError(GantryError, TypeError):
    """A library function got an argument of the wrong kind (a number where a path belongs, ...)."""
