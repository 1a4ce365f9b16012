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


@pytest.fixture(scope="session", autouse=True)
def temporary_folders_in_pytests_own(tmp_path_factory):
    """What the code under test keeps in new temporary folders for its user (a private rig's logs,
    notebook 07's work folder) lands in pytest's temporary folder, which pytest prunes, instead of
    piling up in /tmp run after run. Notebook kernels inherit TMPDIR."""
    import tempfile
    folder = str(tmp_path_factory.mktemp("tmp"))
    saved_env, saved_dir = os.environ.get("TMPDIR"), tempfile.tempdir
    os.environ["TMPDIR"] = folder
    tempfile.tempdir = folder
    yield
    tempfile.tempdir = saved_dir
    if saved_env is None:
        os.environ.pop("TMPDIR", None)
    else:
        os.environ["TMPDIR"] = saved_env
