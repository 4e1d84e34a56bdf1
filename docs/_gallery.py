"""sphinx-gallery helpers for the gallery of diagrams/ (named by string in docs/conf.py, so the
configuration stays picklable).

The diagram scripts save their figures with :func:`sobolev_drake.plots.save_figure`, which
closes them, and write Meshcat recordings beside them; the scraper picks up the PNG files each
code block wrote into the scripts' output folder instead of reading open matplotlib figures.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from sphinx_gallery.scrapers import figure_rst

#: where the gallery's scripts write (their ``out_dir`` argument); inside the build folder
OUT = Path(__file__).resolve().parents[1] / "build" / "gallery-out"
#: simulated seconds per script in the gallery (their defaults are 5-10 s)
DURATION = {"pendulum_tracking": "4", "acrobot_partition": "4", "acrobot_upright": "4",
            "gripper_tracking": "2", "tiltrotor_lqr_hover": "2"}
_seen: set[Path] = set()


def reset_argv(gallery_conf, script_vars):
    """The command line each script sees: a short duration (where it takes one) and OUT."""
    stem = Path(script_vars["src_file"]).stem
    out = str(OUT / stem)
    return [DURATION[stem], out] if stem in DURATION else [out]


def png_scraper(block, block_vars, gallery_conf, **kwargs):
    """The PNG files written into OUT/<script>/ since the previous block, as gallery figures."""
    folder = OUT / Path(block_vars["src_file"]).stem
    new = sorted(p for p in folder.glob("*.png") if p not in _seen) if folder.is_dir() else []
    images = []
    for png, target in zip(new, block_vars["image_path_iterator"]):
        shutil.copyfile(png, target)
        _seen.add(png)
        images.append(target)
    return figure_rst(images, gallery_conf["src_dir"])
