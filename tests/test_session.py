"""The test session's own settings (tests/conftest.py) hold in the test processes."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest


def test_sb3_loggers_write_in_the_sessions_own_folder() -> None:
    """A logger made without a folder (what ``learn`` makes) goes to the session's ``SB3_LOGDIR``,
    not to a new ``SB3-<date and time>`` folder in the system's temporary folder."""
    utils = pytest.importorskip("stable_baselines3.common.utils")
    folder = Path(os.environ["SB3_LOGDIR"])
    logger = utils.configure_logger(verbose=0)
    assert Path(logger.get_dir()) == folder and folder.is_dir()
    assert folder != Path(tempfile.gettempdir()) and not folder.name.startswith("SB3-")
