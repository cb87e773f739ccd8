"""Keywords renamed in the runtime's API: a caller passing an old one gets a TypeError that names
the new keyword (one name per quantity, ``docs/library-format.md``, "Names"), not Python's bare
"unexpected keyword argument"."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

P = ParamSpec("P")
R = TypeVar("R")


def renamed(**old_to_new: str) -> Callable[[Callable[P, R]], Callable[P, R]]:
    """Refuse the old keywords of a function, naming the new one of each (``old="new"``)."""

    def wrap(fn: Callable[P, R]) -> Callable[P, R]:
        @functools.wraps(fn)
        def call(*args: P.args, **kwargs: P.kwargs) -> R:
            for old in old_to_new.keys() & kwargs.keys():
                new = old_to_new[old]
                raise TypeError(f"{fn.__qualname__}(): the keyword {old!r} is now {new!r}; "
                                f"call {fn.__name__}({new}=...) (one name per quantity: docs/library-format.md, Names)")
            return fn(*args, **kwargs)

        return call

    return wrap
