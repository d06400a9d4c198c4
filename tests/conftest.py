"""Test-wide set-up: Qt runs offscreen; matplotlib draws to files."""

import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("MPLBACKEND", "Agg")
