"""Shared fixtures: a small volume written as NRRD, and a container of it
holding both models. TETLOD_CLI (set by ctest) is the built command line."""
import os
import subprocess

import numpy as np
import pytest
import tetlod


@pytest.fixture(scope="session")
def work(tmp_path_factory):
    return tmp_path_factory.mktemp("tetlod")


@pytest.fixture(scope="session")
def volume(work):
    array = tetlod.sample_volume("marschner-lobb", (17, 17, 17), "u8")
    path = str(work / "ml.nrrd")
    tetlod.write_volume(array, path)
    return path, np.array(array)


@pytest.fixture(scope="session")
def container(work, volume):
    path = str(work / "ml.tlod")
    tetlod.convert(volume[0], path, ht=True, mt=True)
    return path


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("TETLOD_CLI")
    if not path:
        pytest.skip("TETLOD_CLI not set (run under ctest)")

    def run(*args):
        subprocess.run([path, "-q", "-f", *args], check=True)

    return run
