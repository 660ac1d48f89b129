"""Run mypy (configured in pyproject.toml) on the installed ``rigtools``.

The repository's folders ``drivers/``, ``sim/`` and ``analysis/`` are ``rigtools.drivers`` etc.
only as installed (the editable install in strict mode links them into one tree). From the
repository's root mypy would take ``./rigtools`` without them, so it runs from a temporary folder;
the findings name the repository's files.
"""

import subprocess
import sys
import tempfile
from pathlib import Path

root = Path(__file__).resolve().parent.parent
with tempfile.TemporaryDirectory() as tmp:
    proc = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(root / "pyproject.toml")],
        cwd=tmp,
        capture_output=True,
        text=True,
        check=False,
    )
out = proc.stdout + proc.stderr
for line in out.splitlines():
    path, sep, rest = line.partition(":")
    if sep and Path(path).exists():
        path = (
            str(Path(path).resolve().relative_to(root)) if Path(path).resolve().is_relative_to(root) else path
        )
    print(path + sep + rest)
sys.exit(proc.returncode)
