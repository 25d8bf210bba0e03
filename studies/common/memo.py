"""``once``: a function's results kept per argument tuple for the life of the process
(``cache_clear()`` forgets them).

Unlike ``functools.lru_cache``, whose wrapper pickles by reference only, the wrapper is a plain
closure: it travels by value with the tasks of a sweep on a Dask cluster, whose workers need not
have the ``studies`` package (common/parallel.py).
"""

from __future__ import annotations

import functools
from typing import Callable


def once(function: Callable) -> Callable:
    results: dict = {}

    @functools.wraps(function)
    def cached(*args):
        if args not in results:
            results[args] = function(*args)
        return results[args]

    cached.cache_clear = results.clear
    return cached
