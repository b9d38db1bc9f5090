"""Shared fixtures: headless plotting for every test."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")
