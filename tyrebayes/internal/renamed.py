"""Keywords the public API renamed: the old word raises a TypeError that names the new one."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

P = ParamSpec("P")
R = TypeVar("R")


def renamed_keyword(old: str, new: str, *, what: str) -> Callable[[Callable[P, R]], Callable[P, R]]:
    """Refuse keyword ``old`` of the decorated function with a TypeError naming ``new``.

    The package speaks one vocabulary (``seed: int`` wherever randomness enters); a call in
    an older word fails loudly instead of being accepted silently beside the new one. ``what``
    says what the new keyword takes, for the message.

    Examples
    --------
    >>> @renamed_keyword("key", "seed", what="an int")
    ... def draw(seed: int = 0) -> int:
    ...     return seed
    >>> draw(seed=3)
    3
    >>> draw(key=3)
    Traceback (most recent call last):
    ...
    TypeError: draw: keyword 'key' is now 'seed' (an int), got key=3
    >>> @renamed_keyword("kind", "model", what="the tyre-curve model")
    ... def curve(model: str = "magic") -> str:
    ...     return model
    >>> curve(kind="brush")
    Traceback (most recent call last):
    ...
    TypeError: curve: keyword 'kind' is now 'model' (the tyre-curve model), got kind='brush'
    """

    def decorate(function: Callable[P, R]) -> Callable[P, R]:
        @functools.wraps(function)
        def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
            if old in kwargs:
                raise TypeError(
                    f"{function.__name__}: keyword {old!r} is now {new!r} ({what}), "
                    f"got {old}={kwargs[old]!r}"
                )
            return function(*args, **kwargs)

        return wrapper

    return decorate
