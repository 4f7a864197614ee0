import os

import numpy as np
import pytest

FAST = os.environ.get("PIPEFLEX_FAST", "0") == "1"


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


# Hypothesis (tests/test_properties.py): derandomised, no example database, no deadline
# (a shared machine's timings vary), so that CI runs the same examples every time.
# HYPOTHESIS_PROFILE=dev lets hypothesis explore new examples on each run.
from hypothesis import settings as _hypothesis_settings  # noqa: E402

_hypothesis_settings.register_profile("ci", derandomize=True, database=None, deadline=None)
_hypothesis_settings.register_profile("dev", deadline=None)
_hypothesis_settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
