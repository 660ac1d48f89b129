"""The wheel users install: one top-level import name, every package folder and data file inside,
and it works from a lab folder that holds its own ``sim.py``, ``analysis.py``, ``drivers.py`` and
``config.py`` (issue 24).

The wheel is built from a copy of the sources in the test's temporary folder (nothing is written
into the repository), with the test environment's setuptools (no build isolation, nothing
downloaded), and installed into a folder of its own. It then runs with ``python -S`` and a
``PYTHONPATH`` of that folder followed by the environment's site-packages: the dependencies come
from the test environment, the repository's own copy (its editable install, its root) cannot be
imported.
"""

from __future__ import annotations

import json
import shutil
import site
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
# repository folder -> the import name it installs as
FOLDERS = {
    "rigtools": "rigtools",
    "drivers": "rigtools.drivers",
    "sim": "rigtools.sim",
    "analysis": "rigtools.analysis",
}
SOURCES = ["pyproject.toml", "README.md", *FOLDERS]


def repository_packages() -> set[str]:
    """Every package (folder with ``__init__.py``) of the repository, by the name it installs as."""
    names = set()
    for folder, name in FOLDERS.items():
        for init in (ROOT / folder).rglob("__init__.py"):
            if "__pycache__" in init.parts:
                continue
            rel = init.parent.relative_to(ROOT / folder).parts
            names.add(".".join((name, *rel)))
    return names


def repository_data_files() -> set[str]:
    """Every file of the four package folders that is not Python source, as its path in the wheel."""
    files = set()
    for folder, name in FOLDERS.items():
        for path in (ROOT / folder).rglob("*"):
            if path.is_dir() or "__pycache__" in path.parts or path.suffix in {".py", ".pyc"}:
                continue
            rel = path.relative_to(ROOT / folder).as_posix()
            files.add(f"{name.replace('.', '/')}/{rel}")
    return files


def wheel_contents(wheel: Path) -> tuple[set[str], set[str], set[str]]:
    """(top-level names, packages, all file names) of a wheel."""
    with zipfile.ZipFile(wheel) as zf:
        names = set(zf.namelist())
    top = {n.split("/", 1)[0] for n in names}
    packages = {n[: -len("/__init__.py")].replace("/", ".") for n in names if n.endswith("/__init__.py")}
    return top, packages, names


def copy_sources(src: Path) -> None:
    """The sources a wheel is built from (:data:`SOURCES`) copied into ``src``."""
    for name in SOURCES:
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(path, src / name)


def build_wheel(src: Path, out: Path) -> Path:
    """Build the wheel of the sources in ``src`` into ``out`` (asserting pip's success); its path."""
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "--no-index",
            "-w",
            str(out),
            str(src),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (wheel,) = out.glob("*.whl")
    return wheel


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    src = tmp_path_factory.mktemp("src")
    copy_sources(src)
    return build_wheel(src, tmp_path_factory.mktemp("dist"))


def test_one_top_level_name_and_every_folder_inside(wheel: Path) -> None:
    top, packages, names = wheel_contents(wheel)
    assert {t for t in top if not t.endswith(".dist-info")} == {"rigtools"}
    missing = repository_packages() - packages
    assert not missing, f"package folders left out of the wheel: {sorted(missing)}"
    missing_data = repository_data_files() - names
    assert not missing_data, f"data files left out of the wheel: {sorted(missing_data)}"
    assert "rigtools/py.typed" in names


def test_a_folder_left_out_is_caught(tmp_path: Path) -> None:
    """The check above fails when pyproject.toml's package list misses a folder."""
    src = tmp_path / "src"
    src.mkdir()
    copy_sources(src)
    pyproject = src / "pyproject.toml"
    text = pyproject.read_text()
    assert '"rigtools.interop", ' in text
    pyproject.write_text(text.replace('"rigtools.interop", ', "", 1))
    wheel = build_wheel(src, tmp_path / "dist")
    _, packages, _ = wheel_contents(wheel)
    assert repository_packages() - packages == {"rigtools.interop"}


def _site_packages() -> list[str]:
    paths = [sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"], *site.getsitepackages()]
    return list(dict.fromkeys(p for p in paths if Path(p).is_dir()))


def test_installed_wheel_runs_from_a_lab_folder(wheel: Path, tmp_path: Path) -> None:
    target = tmp_path / "installed"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--no-deps",
            "--no-index",
            "--target",
            str(target),
            str(wheel),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    lab = tmp_path / "lab"
    lab.mkdir()
    for name in ("sim", "analysis", "drivers", "config"):
        (lab / f"{name}.py").write_text(f'raise ImportError("the lab\'s own {name}.py was imported")\n')
    env = {
        "PYTHONPATH": ":".join([str(target), *_site_packages()]),
        "PATH": "/usr/bin:/bin",
        "HOME": str(tmp_path),
        "MPLBACKEND": "Agg",
        "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
    }
    rig = [sys.executable, "-S", str(target / "bin" / "rig")]

    def run(*args: str) -> str:
        p = subprocess.run(
            list(args), cwd=lab, env=env, capture_output=True, text=True, check=False, timeout=600
        )
        assert p.returncode == 0, f"{args}: {p.stderr[-2000:]}"
        return p.stdout

    assert run(*rig, "--version").strip() == "rig 0.1.0"
    modal = json.loads(run(*rig, "modal", "--json"))
    assert modal["fem"]["active"][0]["frequency_hz"] == pytest.approx(53.21, abs=0.01)  # rig modal's table
    out = lab / "point.h5"
    run(*rig, "simulate", "--duration", "0.05 s", "--no-plot", "--out", str(out), "--json")
    assert out.stat().st_size > 0
    script = lab / "lab_script.py"
    script.write_text(
        "import rigtools\n"
        "from rigtools.config import load_rig\n"
        "print(rigtools.__file__, load_rig().contact.gap)\n"
    )
    printed = run(sys.executable, "-S", str(script)).split()
    assert printed[0].startswith(str(target))
    assert float(printed[1]) == pytest.approx(0.5e-3)
