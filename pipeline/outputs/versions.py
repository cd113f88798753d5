"""Installed versions of distributions, for reports and benchmarks."""

from __future__ import annotations

import platform
from importlib import metadata


def installed_version(distribution: str) -> str | None:
    """The installed version of a distribution (e.g. ``drake``), or None when it is not installed."""
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None


def version_table(*distributions: str) -> dict[str, str]:
    """Python's version and each distribution's ("not installed" when absent), for benchmark reports."""
    return {"python": platform.python_version(),
            **{name: installed_version(name) or "not installed" for name in distributions}}
