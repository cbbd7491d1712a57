"""Shared fixtures of the Python tests (run by ctest with PYTHONPATH set to the
build's python/ directory, or by hand:
    PYTHONPATH=build/python /usr/bin/python3 -m pytest -q python/tests)."""

import os
import pathlib

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("MODAL_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
MODELS = SOURCE_DIR / "models"


@pytest.fixture
def models():
    """The bundled scenes (models/)."""
    return MODELS


@pytest.fixture
def cli():
    """The `modal` command of the same build, for comparisons with what it prints (skips without it)."""
    path = os.environ.get("MODAL_CLI")
    if not path or not os.path.exists(path):
        pytest.skip("MODAL_CLI (the modal command of this build) is not given")
    return path
