import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def plant_fmu():
    path = ROOT / "dist" / "plant.fmu"
    if not path.exists():
        pytest.fail(f"{path} not found: run `make` first")
    return str(path)
