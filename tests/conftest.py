"""Shared test configuration."""

import os

import matplotlib
from hypothesis import settings

matplotlib.use("Agg")

# CI (CI=true) runs the property tests derandomized: the same examples every run, so a
# submission is judged on the code, not on the luck of the draw. Locally they explore.
settings.register_profile("ci", derandomize=True, database=None, deadline=None)
if os.environ.get("CI"):
    settings.load_profile("ci")
