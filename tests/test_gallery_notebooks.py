"""Every gallery example runs as the notebook the site offers for download.

sphinx-gallery turns each script of ``docs/examples/`` into a Jupyter notebook (its own
``jupyter_notebook`` converter, as the docs build does). The notebook's code cells run here in
order in one fresh interpreter whose ``sys.argv`` is a Jupyter kernel's (``-f kernel.json``): a
script that parsed its command line (argparse, ``sys.argv[1]``) fails there as it failed in
Jupyter (``unrecognized arguments: -f``). No Jupyter kernel is needed; the figures are drawn on
matplotlib's Agg backend. The examples are small by design (seconds each, the continuation of
``lab_script.py`` the longest).
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "docs" / "examples").glob("*.py"))


def notebook_code(example: Path) -> str:
    """The code cells of the example's notebook, joined in order."""
    pytest.importorskip("sphinx_gallery", reason="the docs extra (sphinx-gallery) converts the notebooks")
    from sphinx_gallery.notebook import jupyter_notebook
    from sphinx_gallery.py_source_parser import split_code_and_text_blocks

    conf = {
        "first_notebook_cell": None,
        "last_notebook_cell": None,
        "notebook_images": False,
        "promote_jupyter_magic": False,
        "pypandoc": False,
        "notebook_extensions": {"ipynb"},
        "prefer_full_module": set(),
    }
    _, blocks = split_code_and_text_blocks(str(example))[:2]
    notebook = jupyter_notebook(blocks, conf, str(example.parent))
    cells = json.loads(json.dumps(notebook))["cells"]
    return "\n".join("".join(cell["source"]) for cell in cells if cell["cell_type"] == "code")


def test_every_example_is_in_the_gallery_header() -> None:
    header = (ROOT / "docs" / "examples" / "README.md").read_text(encoding="utf-8")
    listed = {line.split("`")[1] for line in header.splitlines() if line.startswith("| `")}
    assert listed == {p.name for p in EXAMPLES}


@pytest.mark.parametrize("example", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs_as_a_notebook(example: Path, tmp_path: Path) -> None:
    code = notebook_code(example)
    assert "argparse" not in code and "sys.argv" not in code
    runner = "import sys\nsys.argv = ['ipykernel_launcher.py', '-f', 'kernel.json']\n" + code
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-c", runner],
        check=False,
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
