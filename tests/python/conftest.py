"""Shared fixtures: where the built binaries are."""
import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def pfm_binary() -> Path:
    build = Path(os.environ.get("PFM_BUILD_DIR", ROOT / "build"))
    binary = build / "bin" / "pfm-mpm"
    if not binary.exists():
        pytest.fail(f"{binary} not built: run `make build` first")
    return binary
