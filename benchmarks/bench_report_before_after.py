"""Two versions of ``psdesign/report/html.py`` in one process, alternated: the same HTML apart
from the PNG bytes, and the CPU time (``time.process_time``) of ``build_html`` and of the K and
convergence tables, on a study folder and on a 2000-row table (``bench_report_old_table``'s).

Session 48 (s48-report2): the old file is the one before the change, e.g.::

    git show f89958d:psdesign/report/html.py > /tmp/html_before.py
    PYTHONPATH=. python benchmarks/bench_report_before_after.py --reps 3 \\
        --old /tmp/html_before.py --folder out/quickstart --big /tmp/big2000

Prints one JSON line per folder (the 2000-row folder is written when missing).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import re
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

#: A PNG ``data:`` URI: its bytes may differ, nothing else may.
PNG = re.compile(r"data:image/png;base64,[A-Za-z0-9+/=]+")


def _module(path: str):
    """``path`` (a copy of psdesign/report/html.py) imported as a module of its own."""
    spec = importlib.util.spec_from_file_location("html_before", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def compare(old, new, folder: Path, reps: int) -> dict:
    """``reps`` rounds of old then new on ``folder``: CPU seconds of each and whether the two
    HTML texts are equal apart from the PNG bytes."""
    texts, times, parts = {}, {"old": [], "new": []}, {"old": [], "new": []}
    df, study, _ = new._load(folder)
    for _round in range(reps):
        for tag, mod in (("old", old), ("new", new)):
            t = time.process_time()
            texts[tag] = mod.build_html(folder)
            times[tag].append(round(time.process_time() - t, 3))
            t = time.process_time()
            mod._k_table(df, study.get("solver"))
            t1 = time.process_time()
            mod._convergence(df)  # the convergence table with its figure
            parts[tag].append([round(t1 - t, 3), round(time.process_time() - t1, 3)])
    return {
        "folder": str(folder),
        "identical_apart_from_png": PNG.sub("PNG", texts["old"]) == PNG.sub("PNG", texts["new"]),
        "png_uris": len(PNG.findall(texts["new"])),
        "html_chars": len(texts["new"]),
        "build_html_cpu_s": times,
        "k_table_and_convergence_cpu_s": parts,
    }


def main() -> None:
    from bench_report_old_table import old_table, write_folder

    import psdesign.report.html as new
    from psdesign.report.interactive import plotly_gz

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--old", default="/tmp/html_before.py")
    ap.add_argument("--folder", default="out/quickstart")
    ap.add_argument("--big", default="/tmp/big2000")
    args = ap.parse_args()
    plotly_gz()  # once per process, in neither's time
    big = Path(args.big)
    if not (big / "results.csv").exists():
        write_folder(old_table(2000), big)
    old = _module(args.old)
    for folder in (Path(args.folder), big):
        print(json.dumps(compare(old, new, folder, args.reps)))


if __name__ == "__main__":
    main()
