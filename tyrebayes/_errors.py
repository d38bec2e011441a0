"""Errors the package raises on bad user input."""


class BadInputError(ValueError):
    """Input that cannot be used: a missing file or column, a wrong unit, an invalid value.

    Its message is one line that names what was expected and what was found. The CLI turns it
    into exit code 2.

    Examples
    --------
    >>> from tyrebayes import read_stream
    >>> try:
    ...     read_stream("no_such_drive.csv")
    ... except BadInputError as err:
    ...     print(err, isinstance(err, ValueError))
    stream file: expected a readable file, got 'no_such_drive.csv' True
    """
