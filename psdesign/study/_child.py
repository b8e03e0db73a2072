"""Child-process entry point for a case with a timeout: ``python -m psdesign.study._child IN OUT``.

Reads the pickled case input from IN, runs the case function and writes a pickled
``{"ok": bool, "results" | "error", "traceback"}`` to OUT (temp file + os.replace).
"""

from __future__ import annotations

import os
import pickle
import sys
import traceback
from pathlib import Path


def main(argv: list[str]) -> int:
    inp, outp = Path(argv[0]), Path(argv[1])
    from psdesign.study.casefn import load_case_fn, watch_parent

    if len(argv) > 2:
        watch_parent(int(argv[2]))
    with open(inp, "rb") as fh:
        job = pickle.load(fh)

    try:
        fn = load_case_fn(job["case_fn"])
        res = fn(job["spec"], list(job["outputs"]), job["solver"], Path(job["workdir"]))
        out = {"ok": True, "results": res}
    except Exception as exc:  # noqa: BLE001 - reported to the parent
        msg = " ".join(str(exc).split())
        out = {
            "ok": False,
            "error": f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__,
            "traceback": traceback.format_exc(),
        }
    tmp = outp.with_name(outp.name + ".tmp")
    with open(tmp, "wb") as fh:
        pickle.dump(out, fh)
    os.replace(tmp, outp)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
