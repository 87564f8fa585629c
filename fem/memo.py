"""Results a model keeps per design, so that the same design asked again costs nothing.

The report's steps ask the same models for the same designs (the base case, the thesis cases)
more than once; a kept result is the one a new solve would give, bit for bit.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import TypeVar

T = TypeVar("T")

#: The attribute of a model that holds its kept results.
KEPT_ATTRIBUTE = "_static_memo"


def kept_result(owner, key: Hashable, compute: Callable[[], T], limit: int) -> T:
    """``compute()``, kept on ``owner`` by ``key``: the same key again returns the kept result.

    The last ``limit`` results are kept (the least recently asked for is dropped first).
    """
    memo = owner.__dict__.setdefault(KEPT_ATTRIBUTE, OrderedDict())
    if key in memo:
        memo.move_to_end(key)
        return memo[key]
    result = memo[key] = compute()
    while len(memo) > limit:
        memo.popitem(last=False)
    return result
