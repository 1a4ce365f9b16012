"""Shared set-up of the Python tests: the module from this build (PYTHONPATH, set by ctest) and
the project root as the working directory (ctest runs them from there)."""
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PUMA = os.path.join(ROOT, "config/robots/puma260.yaml")


@pytest.fixture(scope="session")
def puma():
    import sirupp
    return sirupp.Model(PUMA)


def bin_dir():
    value = os.environ.get("SIRUPP_BIN_DIR")
    if not value:
        pytest.fail("SIRUPP_BIN_DIR not set: run these tests through ctest")
    return value


assert sys.executable.startswith("/usr/bin/"), "run the tests with Debian's /usr/bin/python3"
