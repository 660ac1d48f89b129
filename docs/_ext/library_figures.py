"""sphinx-gallery scraper for the toolkit's figures.

``rigtools.analysis.plots`` builds :class:`matplotlib.figure.Figure` objects directly, outside
pyplot (no GUI backend, pyplot's figure list left alone), so sphinx-gallery's matplotlib scraper
does not see them. This one saves every Figure an example holds in a variable, once, after the code
block that made it.
"""

from pathlib import PurePosixPath
from typing import Any

from sphinx_gallery.scrapers import figure_rst


def scraper(block: Any, block_vars: dict[str, Any], gallery_conf: dict[str, Any]) -> str:
    """Save the example's new Figures and return the reST that shows them."""
    from matplotlib.figure import Figure

    seen: set[int] = block_vars.setdefault("library_figures_seen", set())
    new = []
    for value in list(block_vars["example_globals"].values()):
        if isinstance(value, Figure) and id(value) not in seen and value.canvas.manager is None:
            seen.add(id(value))
            new.append(value)
    rst = []
    for fig, path in zip(new, block_vars["image_path_iterator"], strict=False):
        image_path = PurePosixPath(path)
        fig.savefig(image_path, dpi=100)
        rst.append(figure_rst([image_path], gallery_conf["src_dir"]))
    return "".join(rst)
