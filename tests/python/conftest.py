# What the tests of the Python module share: the shipped scenes, the command line, a PLY reader.
import os

import numpy as np
import pytest

SOURCE_DIR = os.environ["SNOWSIM_SOURCE_DIR"]
BINARY = os.environ["SNOWSIM_BINARY"]


def scene_path(name):
    return os.path.join(SOURCE_DIR, "scenes", name + ".json")


def read_ply(path):
    """A frame's vertex columns by name (float32) and its ids, as sim/io/ply.cpp writes them."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    names, count, element = [], 0, None
    for line in data[:end].decode().splitlines():
        words = line.split()
        if words[0] == "element":
            element = words[1]
            count = int(words[2]) if element == "vertex" else count
        elif words[:2] == ["property", "float"] and element == "vertex":
            names.append(words[2])
    row = len(names) + 1
    values = np.frombuffer(data, dtype="<f4", count=count * row, offset=end).reshape(count, row)
    columns = {name: values[:, k] for k, name in enumerate(names)}
    columns["id"] = values[:, -1].view("<i4")
    return columns


@pytest.fixture
def snowsim():
    import snowsim as module

    return module
