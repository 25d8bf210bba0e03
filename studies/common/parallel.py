"""Run a function over a list of independent items (a sweep): serially, in a local process
pool, or on a Dask distributed cluster when a scheduler address is given.

On a cluster the function and the ``studies`` modules it uses are sent with the tasks (pickled
by value), so the workers need Debian's Python packages but not the checkout; they find
``pfm-mpm`` through ``PFM_MPM`` or on their PATH, and write their runs to ``PFM_CACHE``, which
the client reads: a folder that client and workers share (studies/README.md).

The result list keeps the order of ``items`` whatever the completion order.
``dask.distributed`` is imported only when a scheduler is given; if it is not installed the
call fails with a message saying so (Debian: ``apt-get install python3-distributed``).
"""

from __future__ import annotations

import os
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Callable, Iterable, Optional

from tqdm import tqdm


class SchedulerUnavailable(RuntimeError):
    pass


def default_jobs() -> int:
    return max(1, os.cpu_count() or 1)


def parallel_map(
    function: Callable,
    items: Iterable,
    jobs: Optional[int] = None,
    scheduler: Optional[str] = None,
    description: str = "",
) -> list:
    """``[function(item) for item in items]`` run in parallel; ``function`` must be picklable
    (a module-level function). ``jobs`` = 1 runs serially in this process."""
    items = list(items)
    # Progress on stderr: redrawn on a terminal, every 5 s in a pipe or a log.
    bar = tqdm(
        total=len(items),
        desc=description,
        file=sys.stderr,
        mininterval=0.1 if sys.stderr.isatty() else 5.0,
        ascii=not sys.stderr.isatty(),
        disable=len(items) == 0,
    )
    results = [None] * len(items)
    try:
        if scheduler:
            try:
                from dask.distributed import Client, as_completed as dask_as_completed
            except ImportError as error:
                raise SchedulerUnavailable(
                    f"--scheduler {scheduler} given but dask.distributed cannot be imported "
                    f"({error}); install it (Debian: apt-get install python3-distributed) or "
                    f"run without --scheduler"
                ) from error
            # The workers need not have the checkout: the package's functions travel with the
            # tasks, by value (cloudpickle), and with them every module of the package they use.
            # Each module is registered by name: Dask pickles a function with cloudpickle only
            # when the registry names the function's own module.
            import cloudpickle

            modules = [
                module
                for name, module in sorted(sys.modules.items())
                if name == "studies" or name.startswith("studies.")
            ]
            for module in modules:
                cloudpickle.register_pickle_by_value(module)
            try:
                with Client(scheduler) as client:
                    futures = client.map(function, items, pure=False)
                    index = {future.key: i for i, future in enumerate(futures)}
                    for future in dask_as_completed(futures):
                        results[index[future.key]] = future.result()
                        bar.update()
            finally:
                for module in modules:
                    cloudpickle.unregister_pickle_by_value(module)
            return results
        jobs = jobs or default_jobs()
        if jobs <= 1 or len(items) <= 1:
            for i, item in enumerate(items):
                results[i] = function(item)
                bar.update()
            return results
        with ProcessPoolExecutor(max_workers=min(jobs, len(items))) as pool:
            futures = {pool.submit(function, item): i for i, item in enumerate(items)}
            for future in as_completed(futures):
                results[futures[future]] = future.result()
                bar.update()
        return results
    finally:
        bar.close()
