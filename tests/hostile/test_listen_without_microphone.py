"""Review 12.9: `cyborg listen` on a machine without a microphone said so, but only after loading
the recogniser's model (102 s at load 45, 40 s of it the model). Now it looks for the microphone
first and says so at once."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

import cyborg.hearing.audio
import cyborg.hearing.module
from cyborg.cli import cli
from cyborg.hearing import HearingError
from cyborg.hearing.audio import NO_MICROPHONE


def test_listen_names_the_missing_microphone_before_loading_a_model(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def no_microphone(device: Any = None) -> str:
        raise HearingError(NO_MICROPHONE.format(detail="Error querying device -1"))

    def no_model(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("the recogniser's model was loaded before the microphone was looked for")

    monkeypatch.setattr(cyborg.hearing.audio, "probe_microphone", no_microphone)
    monkeypatch.setattr(cyborg.hearing.module, "recogniser_of", no_model)
    result = CliRunner().invoke(cli, ["listen", "--no-send", "--db", str(tmp_path / "navigation.db")])
    assert result.exit_code == 1, result.output
    assert "no microphone to listen to (Error querying device -1); fix: plug one in" in result.output
