"""What the packaged robot's modules listen for, as the composition root hands it to the ears."""

from __future__ import annotations

import pytest

from cyborg.app.config import load_config, packaged_config
from cyborg.app.context import heard_by
from cyborg.app.registry import module_kinds
from cyborg.modules.kind import Listening


@pytest.fixture(scope="session")
def listening() -> Listening:
    """The packaged Cyborg's navigation requests and answers, and its conversation's greetings."""
    return heard_by(load_config(packaged_config("cyborg.yaml")), module_kinds())()
