"""Installed the way users install it (issue 25, item 1): the wheel holds every module and data
file of the source tree, and a non-editable install of it renders on the compiled and tandem
engines — the editable install the rest of the suite runs from cannot show a part left out of
the wheel (as `emulator/compiled/` once was).

The wheel is built from a copy of the tree (pip's isolated build: setuptools from the index, as
`pip install .` does) and installed with `--no-deps` into a fresh venv that sees this
interpreter's site-packages (numpy, numba, ... already installed) through a `.pth` line — which
adds the folder without running its `.pth` files, so the editable install's finder stays out:
the test checks that `netsushisen` imports from the venv's own copy.
"""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def package_dir() -> dict[str, str]:
    with open(ROOT / "pyproject.toml", "rb") as f:
        return tomllib.load(f)["tool"]["setuptools"]["package-dir"]


def source_files() -> set[str]:
    """Every file the package should install, as its path inside the wheel (`netsushisen/...`):
    each mapped folder's files but caches and compiled bytecode."""
    out = set()
    for package, folder in package_dir().items():
        root = ROOT / folder
        for path in root.rglob("*"):
            rel = path.relative_to(root)
            if not path.is_file() or "__pycache__" in rel.parts or path.suffix in (".pyc", ".o"):
                continue
            if package == "netsushisen" and rel.parts[0] in {f for p, f in package_dir().items()
                                                             if p != "netsushisen"}:
                continue
            out.add("/".join((*package.split("."), *rel.parts)))
    return out


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """A wheel built from a copy of the source tree (the tree itself stays clean)."""
    d = tmp_path_factory.mktemp("wheel")
    src = d / "src"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build")
    src.mkdir()
    for name in ("pyproject.toml", "setup.py", "README.md"):
        shutil.copy(ROOT / name, src / name)
    for folder in set(package_dir().values()):
        shutil.copytree(ROOT / folder, src / folder, ignore=ignore)
    out = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(d / "dist"),
                          str(src)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    (built,) = (d / "dist").glob("netsushisen-*.whl")
    return built


def test_the_wheel_holds_every_module_and_data_file_of_the_tree(wheel):
    names = {n for n in zipfile.ZipFile(wheel).namelist() if not n.split("/")[0].endswith(".dist-info")}
    expected = source_files()
    assert "netsushisen/emulator/compiled/loop.py" in expected  # the part once left out
    assert "netsushisen/asm/grammar.lark" in expected and "netsushisen/kernels/ic.s" in expected
    assert names == expected, (f"missing from the wheel: {sorted(expected - names)}; "
                               f"not in the tree: {sorted(names - expected)}")


def test_the_wheel_declares_pandas_and_numba(wheel):
    meta = zipfile.ZipFile(wheel).read(next(n for n in zipfile.ZipFile(wheel).namelist()
                                            if n.endswith(".dist-info/METADATA"))).decode()
    requires = [line.split(":", 1)[1].strip() for line in meta.splitlines()
                if line.startswith("Requires-Dist:") and "extra ==" not in line]
    assert {r.split(">")[0].split("[")[0].split("=")[0].strip() for r in requires} >= {
        "numpy", "numba", "pandas", "lark", "rich", "matplotlib", "dask", "pyarrow"}


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    """A fresh venv with the wheel installed (not editable); its bin folder."""
    venv = tmp_path_factory.mktemp("venv") / "v"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True,
                   timeout=120)
    python = venv / "bin" / "python"
    purelib = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    here = [p for p in site.getsitepackages() + [site.getusersitepackages()] if os.path.isdir(p)]
    Path(purelib, "zz_dependencies.pth").write_text("\n".join(here) + "\n")
    out = subprocess.run([str(python), "-m", "pip", "install", "--no-deps", "--no-index", "-q",
                          str(wheel)], capture_output=True, text=True, timeout=300, env=_env())
    assert out.returncode == 0, out.stderr[-3000:]
    return venv / "bin"


def _env() -> dict[str, str]:
    """This environment without a PYTHONPATH that could put the source tree first."""
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}


def test_the_installed_copy_is_the_one_imported(installed):
    out = subprocess.run([str(installed / "python"), "-c",
                          "import netsushisen.emulator.compiled as c, netsushisen.asm as a; "
                          "print(c.__file__); print(a.__file__)"],
                         capture_output=True, text=True, timeout=120, env=_env(), cwd=installed)
    assert out.returncode == 0, out.stderr
    for line in out.stdout.splitlines():
        assert Path(line).is_relative_to(installed.parent), line


@pytest.mark.parametrize("engine", ["compiled", "tandem"])
def test_an_installed_wheel_renders_on_the_engine(installed, tmp_path, engine):
    out = subprocess.run([str(installed / "netsushisen"), "render", "tetra", "--res", "8",
                          "--engine", engine, "-o", "t.png", "--json", "s.json"],
                         capture_output=True, text=True, timeout=600, env=_env(), cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert f"{engine} engine: finished" in " ".join(out.stdout.split())
    assert f'"engine": "{engine}"' in (tmp_path / "s.json").read_text()
    assert (tmp_path / "t.png").stat().st_size > 0
