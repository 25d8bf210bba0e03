"""The sweep runner on a live Dask distributed scheduler (``make study SCHEDULER=...``)."""

import pytest

from studies.common.parallel import parallel_map


def square(x):
    return x * x


def test_parallel_map_on_a_live_scheduler_keeps_the_order():
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        items = list(range(20))
        assert parallel_map(square, items, scheduler=cluster.scheduler_address) == [
            x * x for x in items
        ]
