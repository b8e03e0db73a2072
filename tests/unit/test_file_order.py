"""The README's ``-n 2 --dist loadfile`` hands the costliest test files out first.

Truth: the longest-processing-time rule (files longest first, the idle tail at most the last
file handed out) over session 49's measured cold-run times (``tests/file_order.py``), against
xdist's own rule (most tests first), which handed a 2-test, 42 s file out last.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import file_order

REPO = Path(__file__).resolve().parents[2]


def _items(nodeids: list[str]) -> list[SimpleNamespace]:
    return [SimpleNamespace(nodeid=n) for n in nodeids]


def test_heavy_files_go_first_then_the_rest_by_test_count() -> None:
    heavy_a, heavy_b = file_order.HEAVY[0], file_order.HEAVY[1]
    nodeids = [
        "tests/unit/test_small.py::t1",
        "tests/unit/test_many.py::t1",
        f"{heavy_b}::t1",
        "tests/unit/test_many.py::t2",
        "tests/unit/test_tie.py::t1",
        f"{heavy_b}::t2",
        "tests/unit/test_many.py::t3",
        f"{heavy_a}::only",
    ]
    got = [i.nodeid for i in file_order.heavy_files_first(_items(nodeids))]
    assert got == [
        f"{heavy_a}::only",  # HEAVY's order, whatever the counts (1 test here)
        f"{heavy_b}::t1",
        f"{heavy_b}::t2",
        "tests/unit/test_many.py::t1",  # then most tests first, each file's order kept
        "tests/unit/test_many.py::t2",
        "tests/unit/test_many.py::t3",
        "tests/unit/test_small.py::t1",  # one test each: the collection's order
        "tests/unit/test_tie.py::t1",
    ]


def test_only_workers_reorder_and_only_loadfile_keeps_the_order() -> None:
    """A worker's own ``dist`` option is always ``"no"`` (xdist's ``remote.setup_config``)."""
    nodeids = ["tests/unit/test_many.py::t1", f"{file_order.HEAVY[0]}::t"]
    for dist, worker, moved in (
        ("no", True, True),  # a worker of any controller
        ("loadfile", False, False),  # the controller: its collection is not used
        ("no", False, False),  # one process, no xdist
    ):
        config = SimpleNamespace(option=SimpleNamespace(dist=dist, loadscopereorder=True))
        if worker:
            config.workerinput = {}
        items = _items(nodeids)
        file_order.reorder(config, items)
        assert (items[0].nodeid != nodeids[0]) is moved
        file_order.keep_file_order(config)
        assert config.option.loadscopereorder is (dist != "loadfile")
    without_xdist = SimpleNamespace(option=SimpleNamespace())  # -p no:xdist: no such options
    file_order.keep_file_order(without_xdist)
    assert not hasattr(without_xdist.option, "loadscopereorder")


def test_every_heavy_file_is_a_test_file() -> None:
    """A renamed or removed file would silently lose its place at the front."""
    assert len(set(file_order.HEAVY)) == len(file_order.HEAVY)
    for name in file_order.HEAVY:
        assert (REPO / name).is_file(), name
        assert Path(name).name.startswith("test_")
