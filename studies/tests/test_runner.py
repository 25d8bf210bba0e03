"""The runner against a stand-in pfm-mpm: the UL-FEM through `run --solver ulfem`, runs that
stop early, the PFM_MPM setting, and a cache key that ignores unrelated edits."""

import shutil
import stat
from pathlib import Path

import pytest

from studies.common import runner
from studies.common.cache import Cache
from studies.common.outputs import read_index, run_status
from studies.common.paths import mpm_executable
from studies.tests import fake_mpm

CASE = {
    "title": "block",
    "bodies": [{"rectangle": [[0, 0], [2, 1]]}],
    "time": {"end_time": 0.2},
    "output": {"interval": 0.1},
    "detection": {"method": "pfm"},
}


@pytest.fixture
def fake(isolated):
    tool = isolated["bin"] / "pfm-mpm"
    shutil.copy(Path(fake_mpm.__file__), tool)
    tool.chmod(tool.stat().st_mode | stat.S_IXUSR)
    runner._run_help.cache_clear()
    return isolated


def test_ulfem_runs_through_the_solver_option(fake):
    assert runner.mpm_has_solver_option()
    result = runner.run_mpm(CASE, solver="ulfem")
    assert "--solver" in result.command and result.command[-1] != "mpm"
    boundary = read_index(result.out, "boundary")
    assert list(boundary["step"]) == [0, 7, 14]
    again = runner.run_mpm(CASE, solver="ulfem")
    assert again.cache_hit and again.folder == result.folder
    assert not runner.run_mpm(
        CASE, solver="mpm"
    ).cache_hit  # another solver, another key


def test_a_stopped_run_is_a_result_only_when_allowed(fake):
    stopping = dict(CASE, title="stop-early")
    with pytest.raises(runner.RunFailed) as error:
        runner.run_mpm(stopping)
    assert error.value.returncode == 3 and not list(
        Path(fake["cache"]).rglob("run.json")
    )
    result = runner.run_mpm(stopping, allow_stopped=True)
    assert result.stopped and run_status(result.out)["error"] == "CFL violated"
    with pytest.raises(runner.RunFailed):  # cached as stopped, still refused
        runner.run_mpm(stopping)
    assert runner.run_mpm(stopping, allow_stopped=True).cache_hit


def test_pfm_mpm_setting_picks_the_executable(fake, monkeypatch, tmp_path):
    other = tmp_path / "elsewhere" / "pfm-mpm"
    other.parent.mkdir()
    shutil.copy(fake["bin"] / "pfm-mpm", other)
    monkeypatch.setenv("PFM_MPM", str(other))
    assert mpm_executable() == other.resolve()
    monkeypatch.setenv("PFM_MPM", str(tmp_path / "missing"))
    with pytest.raises(Exception, match="PFM_MPM"):
        mpm_executable()


def test_cache_key_ignores_the_repository_state(fake, monkeypatch):
    first = runner.run_mpm(CASE)
    from studies.common import gitinfo

    monkeypatch.setattr(gitinfo, "diff_hash", lambda: "another edit elsewhere")
    assert (
        runner.run_mpm(CASE).cache_hit and runner.run_mpm(CASE).folder == first.folder
    )
    assert Cache().prune(max_bytes=0) > 0 and not first.folder.exists()
