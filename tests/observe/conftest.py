"""Scenario D recorded once for the recorder's tests (a run takes seconds); each test gets copies."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tests.observe.test_recorder import record_d


@pytest.fixture(scope="session")
def _d_recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, str]:
    return record_d(tmp_path_factory.mktemp("scenario_d"))


@pytest.fixture
def d_run(_d_recorded: tuple[Path, Path, str], tmp_path: Path) -> tuple[Path, Path, str]:
    """Scenario D's transcript and recording (copies in this test's folder) and what the run printed."""
    transcript, recording, output = _d_recorded
    copies = tmp_path / transcript.name, tmp_path / recording.name
    shutil.copyfile(transcript, copies[0])
    shutil.copyfile(recording, copies[1])
    return copies[0], copies[1], output
