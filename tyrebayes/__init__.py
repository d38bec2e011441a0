"""tyrebayes: tyre parameters with honest uncertainty from the sensors every car already has."""

from ._errors import BadInputError as BadInputError
from .inference.summary import summarize as summarize

__version__ = "0.1.0"
