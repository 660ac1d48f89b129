"""The figure helper process (:mod:`rigtools.plot_process`): a real second interpreter draws the
PNG; whatever goes wrong there, the command draws it itself, and no helper outlives its block."""

import os
import pickle
from pathlib import Path

import numpy as np
import pytest

from rigtools.model_options import write_plot
from rigtools.plot_process import FigureCall, PlotProcess

PNG = b"\x89PNG\r\n\x1a\n"


def _gone(pid: int) -> bool:
    """The helper has ended and been reaped (no zombie left either)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def _run_figure() -> FigureCall:
    """A 60 Hz run's figure from a made-up two-blade response (3 periods of contact)."""
    t = np.arange(2000) / 20000.0
    u = 1e-3 * np.sin(2 * np.pi * 60 * t)
    a = -((2 * np.pi * 60) ** 2) * u
    force = 15 * np.sin(2 * np.pi * 60 * t)
    contact = np.maximum(u - 0.5e-3, 0) * 1e5
    return FigureCall(
        "rigtools.analysis.plots", "vibro_impact_figure", t, u, 0.5 * u, contact, a, 0.5 * a, 60.0,
        gap=0.5e-3, title="helper test", force=force,
    )  # fmt: skip


def test_figure_call_pickles_without_its_module_and_draws_the_same():
    call = _run_figure()
    again = pickle.loads(pickle.dumps(call))
    assert (again.module, again.function) == ("rigtools.analysis.plots", "vibro_impact_figure")
    assert [len(fig.axes) for fig in (call(), again())] == [4, 4]


def test_the_helper_writes_the_png(tmp_path):
    path = tmp_path / "run.png"
    with PlotProcess() as helper:
        pid = helper._proc.pid
        assert helper.write(_run_figure(), path) is True
    assert _gone(pid)
    data = path.read_bytes()
    assert data[:8] == PNG
    assert b"Software" in data and b"rigtools" in data  # rigtools.figures.save_figure's mark
    from matplotlib.image import imread

    assert imread(path).shape[:2] == (900, 1200)  # 12 x 9 in at 100 dpi
    assert [p.name for p in tmp_path.iterdir()] == ["run.png"]  # no temporary file left


def test_a_figure_the_helper_cannot_draw_is_drawn_here_with_its_error(tmp_path):
    """The figure's own error is reported once, by this process (the one way errors surface)."""
    bad = FigureCall("rigtools.analysis.plots", "vibro_impact_figure", np.zeros(1), *[np.zeros(1)] * 5, 60.0)
    with PlotProcess() as helper:
        pid = helper._proc.pid
        with pytest.raises(ValueError, match="need at least 2 samples"):
            write_plot(False, tmp_path / "run.h5", bad, helper)
    assert _gone(pid)
    assert list(tmp_path.iterdir()) == []


def test_a_figure_that_does_not_pickle_is_drawn_here(tmp_path):
    call = _run_figure()
    with PlotProcess() as helper:
        assert helper.write(lambda: call(), tmp_path / "lambda.png") is False
        assert helper._proc is None  # ended by the failed hand-over
    png = write_plot(False, tmp_path / "run.h5", lambda: call(), PlotProcess())
    assert png == tmp_path / "run.png" and png.read_bytes()[:8] == PNG


def test_a_helper_left_unused_is_ended_with_its_block():
    with PlotProcess() as helper:
        pid = helper._proc.pid
    assert _gone(pid)


def test_a_helper_that_died_leaves_the_figure_to_this_process(tmp_path):
    with PlotProcess() as helper:
        helper._proc.kill()
        helper._proc.wait()
        png = write_plot(False, tmp_path / "run.h5", _run_figure(), helper)
    assert png == tmp_path / "run.png" and png.read_bytes()[:8] == PNG


def test_no_plot_starts_no_helper(tmp_path):
    from rigtools.model_options import plot_ahead

    with plot_ahead(True) as helper:
        assert helper is None
        assert write_plot(True, tmp_path / "run.h5", _run_figure(), helper) is None
    assert list(tmp_path.iterdir()) == []


def test_the_helper_ignores_a_lab_folders_own_modules(tmp_path):
    """Started with -P: a ``matplotlib.py`` in the working folder is not imported in its place."""
    (tmp_path / "matplotlib.py").write_text("raise ImportError('the lab folder was imported')\n")
    cwd = Path.cwd()
    os.chdir(tmp_path)
    try:
        with PlotProcess() as helper:
            assert helper.write(_run_figure(), tmp_path / "run.png") is True
    finally:
        os.chdir(cwd)


def test_the_helper_imports_the_commands_own_rigtools(tmp_path):
    """A command whose rigtools comes from a folder the environment does not name (a checkout run
    as ``python -m rigtools.cli`` from its root, a path added at run time): the helper draws with
    that rigtools, not with the one installed or on PYTHONPATH."""
    import subprocess
    import sys

    import rigtools

    repo = Path(rigtools.__file__).resolve().parent.parent
    checkout = tmp_path / "checkout"
    checkout.mkdir()
    for name in ("rigtools", "sim", "analysis", "drivers"):
        (checkout / name).symlink_to(repo / name, target_is_directory=True)
    seen = tmp_path / "seen.txt"
    script = f"""
import sys
sys.path.insert(0, {str(checkout)!r})
from pathlib import Path
import rigtools
from rigtools.plot_process import FigureCall, PlotProcess
assert rigtools.__file__.startswith({str(checkout)!r}), rigtools.__file__
probe = "import rigtools; open({str(seen)!r}, 'w').write(rigtools.__file__)"
with PlotProcess() as helper:
    helper.write(FigureCall("builtins", "exec", probe), Path({str(tmp_path / "probe.png")!r}))
"""
    subprocess.run([sys.executable, "-c", script], cwd=tmp_path, check=True, timeout=120)
    assert seen.read_text() == str(checkout / "rigtools" / "__init__.py")


def test_a_figure_the_helper_draws_leaves_matplotlib_unimported_here(tmp_path):
    """The helper exists so that the command never pays matplotlib's import: nothing of it is
    imported here when the helper draws (nor when a lab folder holds its own ``matplotlib.py``)."""
    import subprocess
    import sys

    (tmp_path / "matplotlib.py").write_text("raise ImportError('the lab folder was imported')\n")
    script = """
import sys
from pathlib import Path
sys.path.insert(0, "")  # the lab folder first, as python -m rigtools.cli has it
from rigtools.model_options import plot_ahead, write_plot
from rigtools.plot_process import FigureCall
import numpy as np
t = np.arange(2000) / 20000.0
u = 1e-3 * np.sin(2 * np.pi * 60 * t)
call = FigureCall("rigtools.analysis.plots", "vibro_impact_figure", t, u, u, u, u, u, 60.0)
with plot_ahead(False) as helper:
    png = write_plot(False, Path("run.h5"), call, helper)
print(png, sorted(m for m in sys.modules if m.split(".")[0] == "matplotlib"))
"""
    done = subprocess.run(
        [sys.executable, "-c", script], check=False, cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert (done.returncode, done.stdout, done.stderr) == (0, "run.png []\n", "")
    assert (tmp_path / "run.png").read_bytes()[:8] == PNG
