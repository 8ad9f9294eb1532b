"""The one exception type the core raises for bad input."""


class InvalidInputError(ValueError):
    """Bad input to the core: the message names the field (and index where there is one)."""
