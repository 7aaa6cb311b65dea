"""Shared fixtures: the OpenCL runtime (PoCL CPU by default) and the third-party assets folder."""
from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ASSETS = ROOT.parent / "shared" / "assets"
SCENES = ROOT / "scenes"


@pytest.fixture(scope="session")
def runtime():
    from clshade.device.runtime import get_runtime
    return get_runtime()


@pytest.fixture(scope="session")
def assets() -> Path:
    """../shared/assets beside the checkout; tests using it skip when it is absent."""
    if not ASSETS.is_dir():
        pytest.skip(f"third-party assets not found at {ASSETS} (only present beside the developers' checkout)")
    return ASSETS
