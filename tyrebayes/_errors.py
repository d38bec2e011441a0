"""Errors the package raises on bad user input."""


class BadInputError(ValueError):
    """Input that cannot be used: a missing file or column, a wrong unit, an invalid value.

    Its message is one line that names what was expected and what was found. The CLI turns it
    into exit code 2.
    """
