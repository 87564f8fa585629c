"""What produced an output: resolved configuration, package versions, git revision."""

from __future__ import annotations

import platform
import subprocess
from importlib import metadata
from pathlib import Path

from . import __version__

_PACKAGES = ("numpy", "scipy", "gmsh", "meshio", "matplotlib", "pypardiso", "scikit-sparse")


def package_versions() -> dict[str, str]:
    """Versions of isj, Python and the numerical packages it uses (absent ones omitted)."""
    out = {"isj": __version__, "python": platform.python_version()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return out


def git_revision() -> str | None:
    """Short git revision of the source tree, if it is a git checkout."""
    try:
        top = Path(__file__).resolve().parent.parent
        r = subprocess.run(
            ["git", "-C", str(top), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
        )
        return r.stdout.strip() or None if r.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        return None


def write_run_record(path, args, results: dict) -> Path:
    """Write ``path`` (JSON, atomically): resolved options, versions, results."""
    from .atomic import atomic_write_json

    config = {k: v for k, v in vars(args).items() if k != "func"}
    record = {
        "config": config,
        "versions": package_versions(),
        "git_revision": git_revision(),
        "results": results,
    }
    return atomic_write_json(path, record)
