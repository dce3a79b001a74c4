"""Test configuration: under CI (``CI=true``) hypothesis runs derandomized, so a CI run is
reproducible; locally it explores new examples every run (and keeps failures in ``.hypothesis/``)."""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
    settings.load_profile("ci")
