"""Every test writes into its own temporary results, cache and build folders."""

import matplotlib
import pytest

matplotlib.use("Agg")


@pytest.fixture
def isolated(tmp_path, monkeypatch):
    """Temporary PFM_RESULTS, PFM_CACHE and an empty PFM_BUILD_DIR (no binaries), no PFM_MPM."""
    paths = {name: tmp_path / name for name in ("results", "cache", "bin")}
    for path in paths.values():
        path.mkdir()
    monkeypatch.setenv("PFM_RESULTS", str(paths["results"]))
    monkeypatch.setenv("PFM_CACHE", str(paths["cache"]))
    monkeypatch.setenv("PFM_BUILD_DIR", str(paths["bin"]))
    monkeypatch.delenv("PFM_MPM", raising=False)
    return paths
