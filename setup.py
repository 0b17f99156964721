"""Package discovery for the one namespace `netsushisen` over the design card's top-level folders.

pyproject.toml maps each folder to its package (`[tool.setuptools] package-dir`); this file finds
every package under each mapped folder (every directory with an `__init__.py`), so a subpackage
added later (as `emulator/compiled/` once was) cannot be left out of the wheel the way a
hand-written list let it. `tests/test_packaging.py` checks the built wheel against the source tree.
"""

from pathlib import Path

import tomllib
from setuptools import setup

HERE = Path(__file__).parent


def package_dir() -> dict[str, str]:
    """The package -> folder mapping of pyproject.toml."""
    with open(HERE / "pyproject.toml", "rb") as f:
        return tomllib.load(f)["tool"]["setuptools"]["package-dir"]


def find_packages(mapping: dict[str, str]) -> list[str]:
    """Every package under the mapped folders: a mapped folder's package, and one for each
    directory below it that has an `__init__.py`, named by its path."""
    found = set()
    for name, folder in mapping.items():
        root = HERE / folder
        for init in root.rglob("__init__.py"):
            rel = init.parent.relative_to(root)
            if "__pycache__" not in rel.parts:
                found.add(".".join((name, *rel.parts)))
    return sorted(found)


setup(packages=find_packages(package_dir()))
