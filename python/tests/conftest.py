"""Fixtures: the repository, the host-sim command line (to compare the package with) and
small variants of the shipped scenarios."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE1 = ROOT / "scenarios" / "example1.toml"
GRID = ROOT / "host-sim" / "tests" / "campaigns" / "grid.toml"


def host_sim_binary() -> Path:
    """HOST_SIM, else the newest host-sim built in target/ (release before debug), else PATH."""
    given = os.environ.get("HOST_SIM")
    if given:
        return Path(given)
    for profile in ("release", "debug"):
        p = ROOT / "target" / profile / "host-sim"
        if p.exists():
            return p
    found = shutil.which("host-sim")
    if found:
        return Path(found)
    pytest.skip("no host-sim binary: cargo build -p host-sim --release, or set HOST_SIM")


@pytest.fixture(scope="module")
def host_sim():
    binary = host_sim_binary()

    def call(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([str(binary), *map(str, args)], check=True, capture_output=True, text=True)

    return call
