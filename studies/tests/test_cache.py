"""The run cache: the same inputs hit, any changed input misses, failures leave nothing."""

import pytest

from studies.common.cache import Cache, cache_key

CASE = {
    "grid": {"cell_size": 0.5, "n_cells": [30, 15]},
    "title": "block",
    "materials": [{"name": "soil", "youngs_modulus": 1000.0}],
}
REV = dict(revision="a" * 40, diff="d" * 64)


def test_key_ignores_key_order_and_whitespace_but_not_values():
    reordered = {
        "title": "block",
        "materials": [{"youngs_modulus": 1000.0, "name": "soil"}],
        "grid": {"n_cells": [30, 15], "cell_size": 0.5},
    }
    assert cache_key(CASE, ["run"], **REV) == cache_key(reordered, ["run"], **REV)
    changed = {**CASE, "grid": {"cell_size": 0.25, "n_cells": [30, 15]}}
    assert cache_key(CASE, ["run"], **REV) != cache_key(changed, ["run"], **REV)


@pytest.mark.parametrize(
    "change",
    [
        {"arguments": ["run", "--threads", "2"]},
        {"revision": "b" * 40},
        {"diff": "e" * 64},
        {"extra": {"executable": "0" * 64}},
    ],
)
def test_key_changes_with_revision_diff_arguments_and_executable(change):
    base = dict(case=CASE, arguments=["run"], **REV)
    assert cache_key(**base) != cache_key(**{**base, **change})


def test_same_key_hits_and_changed_case_misses(tmp_path):
    cache = Cache(tmp_path)
    calls = []

    def make(folder):
        calls.append(folder)
        (folder / "result.txt").write_text("42")

    key = cache_key(CASE, ["run"], **REV)
    folder, hit = cache.produce(key, make)
    assert not hit and len(calls) == 1 and (folder / "result.txt").read_text() == "42"
    again, hit = cache.produce(key, make)
    assert hit and again == folder and len(calls) == 1
    other = cache_key({**CASE, "title": "other"}, ["run"], **REV)
    _, hit = cache.produce(other, make)
    assert not hit and len(calls) == 2


def test_failed_run_leaves_no_entry(tmp_path):
    cache = Cache(tmp_path)
    key = cache_key(CASE, ["run"], **REV)

    def broken(folder):
        (folder / "partial.txt").write_text("half")
        raise RuntimeError("crash")

    with pytest.raises(RuntimeError):
        cache.produce(key, broken)
    assert cache.lookup(key) is None and not cache.folder(key).exists()
