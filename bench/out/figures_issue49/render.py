"""Draw every registered figure from the synthetic inputs of tests/test_figure_layout.py to
bench/out/figures_issue49/<prefix>_<kind>[_paper].png and print each figure's layout faults.
Run from the project root: .venv/bin/python bench/out/figures_issue49/render.py after [KIND...]"""

import pathlib
import shutil
import sys
import tempfile

sys.path.insert(0, "tests")
from test_figure_layout import CASES, draw, layout_faults  # noqa: E402

prefix, only = sys.argv[1], sys.argv[2:]
here = pathlib.Path(__file__).parent
for kind, paper in CASES:
    if only and kind not in only:
        continue
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        fig = draw(kind, tmp, paper)
        name = kind.replace("{name}", "ballmill") + ("_paper" if paper else "")
        faults = layout_faults(fig)
        print(f"{name}: {len(faults)} faults", *faults[:6], sep="\n  ")
        if kind != "animation":
            shutil.copy(next(tmp.glob(f"{name}.png")), here / f"{prefix}_{name}.png")
