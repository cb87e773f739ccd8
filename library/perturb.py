"""The ``--perturb KEY=VALUE,...`` syntax that the model plant's and the twin's error sets share:
items split on commas, each ``KEY=VALUE`` with a known key given once, the value a finite number,
``+10%`` relative. What each key means is the parser's of each plant."""

from __future__ import annotations

import math
from collections.abc import Collection, Iterator


def perturbation_items(text: str, keys: Collection[str], error: type[Exception]
                       ) -> Iterator[tuple[str, str, float, bool]]:
    """Each item of ``text`` as (item, key, number, relative).

    Raises:
        error: Naming the item: no ``=``, a key not in ``keys`` (listing them), a key given twice, a
            value that is not a finite number or percentage.
    """
    seen: set[str] = set()
    for item in filter(None, (s.strip() for s in text.split(","))):
        key, sep, value = (s.strip() for s in item.partition("="))
        if not sep or key not in keys:
            raise error(f"--perturb {item!r}: expected KEY=VALUE with KEY one of {', '.join(keys)}")
        if key in seen:
            raise error(f"--perturb {text!r}: {key} is given twice; give each key once")
        seen.add(key)
        relative = value.endswith("%")
        try:
            number = float(value[:-1] if relative else value)
        except ValueError:
            raise error(f"--perturb {item!r}: {value!r} is not a number or a percentage") from None
        if not math.isfinite(number):
            raise error(f"--perturb {item!r}: must be finite")
        yield item, key, number, relative
