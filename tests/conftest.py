import os

import numpy as np
import pytest

FAST = os.environ.get("PIPEFLEX_FAST", "0") == "1"


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
