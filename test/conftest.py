"""Shared fixtures. DDS is isolated per test run: localhost-only discovery and a domain of our own."""

from __future__ import annotations

import os
import random
from pathlib import Path

import pytest

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(5, 95)))
os.environ.setdefault("MPLBACKEND", "Agg")

REPO = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path:
    """``<repo>/../shared/data`` (CI clones the repo with shared/ beside it)."""
    return REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO


@pytest.fixture(scope="session")
def real_bag() -> Path:
    path = shared_data_dir() / "real" / "xtion_person_32fc1.bag"
    if not path.is_file():
        pytest.fail(f"real-data fixture missing: {path} (the repo must be cloned with shared/ beside it)")
    return path


@pytest.fixture()
def ros_env() -> dict[str, str]:
    """Environment for child processes: same isolated DDS domain, unbuffered output."""
    env = dict(os.environ)
    env["PYTHONUNBUFFERED"] = "1"
    return env
