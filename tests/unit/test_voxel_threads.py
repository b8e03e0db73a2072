"""Thread policy of the voxel Stokes solver (solvers.voxel.threads)."""

from __future__ import annotations

import os
import subprocess
import sys

import numba
import numpy as np
import pytest

from solvers.voxel import multigrid as mg
from solvers.voxel.threads import PARALLEL_MIN_CELLS, level_threads, solve_min_cells, solve_threads


def _wait_policy(env_value: str | None) -> str:
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if env_value is not None:
        env["OMP_WAIT_POLICY"] = env_value
    code = "import os, psdesign; print(os.environ.get('OMP_WAIT_POLICY'))"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    return out.stdout.strip()


def test_import_makes_idle_threads_sleep_but_keeps_a_user_choice() -> None:
    assert _wait_policy(None) == "PASSIVE"
    assert _wait_policy("ACTIVE") == "ACTIVE"


def test_small_levels_run_on_one_thread() -> None:
    assert level_threads(PARALLEL_MIN_CELLS - 1, 8) == 1
    assert level_threads(PARALLEL_MIN_CELLS, 8) == 8
    assert level_threads(10**9, 1) == 1


def test_small_solves_run_on_one_thread() -> None:
    """A 64^3 solve with one competing process ran 1.16-1.59x its one-thread time on two
    threads (issue 16 item 1, session 21, benchmarks/RESULTS.md): it runs on one; 100^3 on
    all."""
    assert solve_threads(64**3, 2) == 1
    assert solve_threads(100**3, 2) == 2
    assert solve_threads(100**3, 1) == 1
    assert solve_min_cells() >= PARALLEL_MIN_CELLS


def test_vcycle_restores_the_callers_thread_count() -> None:
    fluid = np.ones((8, 8, 8), dtype=bool)
    fluid[:, :2, :] = False
    d, c = mg.component_operator(fluid, 0)
    m = mg.ScalarMG(d, c, max_coarse=8)
    before = numba.get_num_threads()
    out = np.zeros(d.shape, np.float32)
    m.apply(np.ones(d.shape, np.float32), out)
    assert numba.get_num_threads() == before
    assert np.all(out[d == 0] == 0.0) and np.all(out[d > 0] > 0.0)


def _twin_kernels() -> list:
    """Every :class:`solvers.jit.TwinKernel` of the loaded solver modules."""
    from solvers.jit import TwinKernel

    mods = [m for name, m in list(sys.modules.items()) if name.startswith("solvers.") and m]
    return [k for m in mods for k in vars(m).values() if isinstance(k, TwinKernel)]


@pytest.mark.parametrize("case", ["not_compiled", "compiled", "small_grid"])
def test_result_states_the_threads_its_kernels_ran_on(case: str, monkeypatch) -> None:
    """Session 11: with the parallel kernels not in numba's cache a two-thread solve below
    ``jit.COMPILE_PARALLEL_ABOVE`` cells ran the serial twins, about 2x slower, and said
    nothing.  Two threads are simulated (numba's thread count as the solver reads and sets
    it; the run needs one real thread only); a "compiled" parallel kernel runs its serial
    twin's code."""
    from solvers import jit
    from solvers import voxel_stokes as vs
    from solvers.voxel import threads as vthreads

    threads = [2]
    monkeypatch.setattr(numba, "get_num_threads", lambda: threads[0])
    monkeypatch.setattr(numba, "set_num_threads", lambda n: threads.__setitem__(0, n))
    if case != "small_grid":
        monkeypatch.setattr(vthreads, "PARALLEL_MIN_CELLS", 0)
        monkeypatch.setattr(vthreads, "SOLVE_PARALLEL_MIN_CELLS", 0)
    monkeypatch.setattr(jit.TwinKernel, "_parallel_ready", lambda self, args: case == "compiled")
    for kernel in _twin_kernels():
        monkeypatch.setattr(kernel, "parallel", kernel.serial)
    solid = np.zeros((12, 12, 12), dtype=bool)
    solid[:, 3:7, 3:7] = True  # a square rod along x, flow along y
    res = vs.solve_voxel_stokes(solid, 1e-6, "y", tol=1e-6)
    assert res.converged and threads == [2]  # the caller's count restored
    if case == "not_compiled":
        assert res.threads_used == 1
        assert "psdesign warmup" in res.thread_note and "1 of 2 threads" in res.thread_note
        assert "stokes_lanczos" in res.serial_fallback
    elif case == "compiled":
        assert (res.threads_used, res.thread_note, res.serial_fallback) == (2, "", ())
    else:
        assert res.threads_used == 1 and res.serial_fallback == ()
        assert res.thread_note == f"ran on 1 of 2 threads: grid below {solve_min_cells()} cells"


@pytest.mark.parametrize("above", [False, True])
def test_a_solve_compiles_parallel_kernels_by_its_grid_cells(above: bool, monkeypatch) -> None:
    """Session 44 (mirror): each kernel compiled its parallel version when its *first argument*
    reached ``jit.COMPILE_PARALLEL_ABOVE`` elements, and a 4-field vector has 4 per cell: a
    120^3 mirror solve (3.4 M cells, below the 10 M of the rule) compiled five vector kernels
    on first use (58 s of its 95 s, 153 MB of peak RSS at load 3.5; ``benchmarks/RESULTS.md``)
    and ran its operator kernels serially all the same.  Now the solved grid's cells decide
    for every kernel of the solve: none compiles below the rule, all run parallel from it.
    Two threads simulated and "compiling" gives the serial twin, as in the test above."""
    from solvers import jit
    from solvers import voxel_stokes as vs
    from solvers.voxel import threads as vthreads

    threads = [2]
    monkeypatch.setattr(numba, "get_num_threads", lambda: threads[0])
    monkeypatch.setattr(numba, "set_num_threads", lambda n: threads.__setitem__(0, n))
    monkeypatch.setattr(vthreads, "PARALLEL_MIN_CELLS", 0)
    monkeypatch.setattr(vthreads, "SOLVE_PARALLEL_MIN_CELLS", 0)
    monkeypatch.setattr(jit.TwinKernel, "_parallel_ready", lambda self, args: False)
    for kernel in _twin_kernels():
        monkeypatch.setattr(kernel, "parallel", kernel.serial)
    solid = np.zeros((12, 12, 12), dtype=bool)
    solid[:, 3:7, 3:7] = True  # a square rod along x, flow along y, mirrored: 12 x 24 x 12
    cells = 12 * 24 * 12
    # the rule at the solved grid's cells, or between them and the vectors' 4 per cell
    monkeypatch.setattr(jit, "COMPILE_PARALLEL_ABOVE", cells if above else 2 * cells)
    res = vs.solve_voxel_stokes(solid, 1e-6, "y", tol=1e-6, periodic_treatment="mirror")
    assert res.converged and threads == [2] and jit.COMPILE_PARALLEL_ABOVE == (2 - above) * cells
    if above:
        assert (res.threads_used, res.thread_note, res.serial_fallback) == (2, "", ())
    else:
        assert res.threads_used == 1 and res.thread_note.startswith("ran on 1 of 2 threads")
        assert {"stokes_lanczos", "symmlq_step"} <= set(res.serial_fallback)


def test_partly_compiled_kernels_are_named() -> None:
    from solvers.voxel.threads import thread_use

    n, note = thread_use(2, 2, {"jacobi"}, {"stokes_lanczos"})
    assert n == 2 and note.startswith("1 kernels ran on 1 of 2 threads (jacobi): ")
    assert thread_use(1, 1, set(), set()) == (1, "")
    assert thread_use(2, 2, set(), {"jacobi"}) == (2, "")


def _scaled_sum(x, scale=None):
    """A parallel kernel with a parameter left to its default (as ``stream`` on s28-stream)."""
    acc = 0.0
    for i in numba.prange(x.size):
        acc += x[i]
    return acc if scale is None else acc * scale


def test_a_compiled_kernel_is_found_when_a_default_is_omitted() -> None:
    """Session 28: numba compiles a call that omits a defaulted parameter under the signature
    ``(..., omitted(default=None))``; ``TwinKernel`` looked it up without that entry, never found
    the compiled parallel kernel and ran the serial twin (on branch s28-stream, where the Jacobi
    sweeps had gained ``stream=None``, the 100^3 level of every V-cycle of a 200^3 solve ran on
    one thread)."""
    from solvers.jit import TwinKernel

    kern = TwinKernel(_scaled_sum)
    x = np.ones(64)
    assert not kern._parallel_ready((x,))
    assert kern.parallel(x) == 64.0  # compiles it, as psdesign warmup does
    kern._ready.clear()
    assert kern._parallel_ready((x,)) and kern._parallel_ready((x, 2.0)) is False


def test_a_solve_on_uncompiled_kernels_gives_the_same_warnings(monkeypatch) -> None:
    """Session 35 (reproducibility audit): a voxel solve whose parallel kernels were not in
    numba's cache added "K_z: voxel solve ran on 1 of 2 threads: parallel kernels not compiled
    yet ..." to the result's ``warnings``, so ``fields.json`` and a study's ``warnings_z``
    column depended on the cache, not on the spec and seed.  The note is kept in
    ``thread_note`` (run metadata: ``thread_note_z`` is a timing column of the study table);
    the warnings are those of a solve on compiled kernels."""
    import dataclasses

    import solvers.voxel_stokes as vsm
    from psdesign.flow import voxel as fv
    from psdesign.geometry.fibers import make_fiber
    from psdesign.geometry.rve import RVE
    from psdesign.study.store import is_timing_column
    from solvers.jit import WARMUP_NOTE

    fib = make_fiber(
        "cylinder", diameter=0.45, center=np.array([0.5, 0.5, 0.5]), theta=None, omega=None,
        direction=[1, 0, 0], u=0.0, f=1.0, isovalue=None,
    )  # fmt: skip
    rve = RVE(size=np.full(3, 20e-6), fibers=[fib])
    fields = rve.voxelize(1e-6)
    real = vsm.solve_voxel_stokes
    results = {}
    for compiled in (True, False):
        note = "" if compiled else f"ran on 1 of 2 threads: {WARMUP_NOTE}"
        fallback = () if compiled else ("stokes_lanczos",)

        def solve(*a, _note=note, _fallback=fallback, **k):
            res = real(*a, **k)  # the real solve, then the cache state of a cold install
            return dataclasses.replace(res, thread_note=_note, serial_fallback=_fallback)

        monkeypatch.setattr(vsm, "solve_voxel_stokes", solve)
        results[compiled] = fv.permeability_voxel(
            fields, "y", {"bc": "periodic", "viscosity": 1e-3, "tol": 1e-6}, rve=rve
        )
    cold, warm = results[False], results[True]
    assert cold["thread_note"].endswith(WARMUP_NOTE) and warm["thread_note"] == ""
    assert cold.get("warnings") == warm.get("warnings")
    assert not any(WARMUP_NOTE in w for w in cold.get("warnings", []))
    assert cold["permeability_m2"] == warm["permeability_m2"]
    assert is_timing_column("thread_note_y") and not is_timing_column("warnings_y")


def _parfor_reductions(fn) -> list[str]:
    """The numba parfor reductions in ``fn``'s source: a ``.sum()`` / ``np.sum`` call, or an
    in-place update of a name that a ``prange`` loop body does not bind itself."""
    import ast
    import inspect
    import textwrap

    tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            if node.func.attr == "sum":
                found.append(f"line {node.lineno}: {ast.unparse(node)}")
        is_prange = (
            isinstance(node, ast.For)
            and isinstance(node.iter, ast.Call)
            and ast.unparse(node.iter.func).endswith("prange")
        )
        if is_prange:
            bound = {
                t.id
                for n in ast.walk(node)
                if isinstance(n, ast.Assign)
                for t in n.targets
                if isinstance(t, ast.Name)
            }
            for n in ast.walk(node):
                if isinstance(n, ast.AugAssign) and isinstance(n.target, ast.Name):
                    if n.target.id not in bound:
                        found.append(f"line {n.lineno}: {ast.unparse(n)}")
    return found


def test_no_kernel_sum_depends_on_the_threading() -> None:
    """Session 36: ``part.sum()`` at the end of a ``parallel=True`` kernel is a numba parfor
    reduction, summed per thread in an order that depends on the threading layer and the
    thread count (OpenMP on two threads: a different last bit on every call of 2 000+
    partials; TBB: from call to call).  The 72^3 solve's true residual differed by one ulp
    between one and two threads (session 35 reproducibility audit).  Every parallel kernel ends
    with :func:`solvers.reduction.ordered_sum` instead; the scan must see the old form."""
    import solvers.transport.kernels  # noqa: F401  (its kernels join the scan)
    import solvers.voxel.cutfaces  # noqa: F401
    import solvers.voxel.lanczos  # noqa: F401
    import solvers.voxel.schur  # noqa: F401
    import solvers.voxel.thin  # noqa: F401

    kernels = _twin_kernels()
    assert len(kernels) >= 30
    found = {k.py_func.__qualname__: _parfor_reductions(k.py_func) for k in kernels}
    assert {name: f for name, f in found.items() if f} == {}
    assert _parfor_reductions(_scaled_sum) == ["line 5: acc += x[i]"]


def _compiled_on_their_own(root) -> dict[str, object]:
    """Functions of ``solvers`` that numba compiles as functions of their own (``@X.slab(...)``,
    ``@X.shared(...)``, ``@nb.njit(...)`` without ``inline``), by name: their AST nodes."""
    import ast

    def own(dec) -> bool:
        if not isinstance(dec, ast.Call):
            return False
        f = dec.func
        name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
        own = ("slab", "shared", "njit")  # SerialHelpers.slab / .shared, plain numba
        return name in own and not any(k.arg == "inline" for k in dec.keywords)

    out = {}
    for path in sorted((root / "solvers").rglob("*.py")):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.FunctionDef) and any(own(d) for d in node.decorator_list):
                out[node.name] = node
    return out


def test_no_separately_compiled_function_calls_another(repo_root) -> None:
    """Session 37: ``_lanczos_slab`` (a cached function of its own) called the flat loop
    ``_lanczos_flat_slab`` (another): the call reached the flat loop's own compile or the copy
    linked into its caller, whichever a process loaded first, and under fastmath the two gave
    other last bits, so a staircase K depended on whether the process had compiled the kernels
    (tests/unit/test_voxel_lanczos.py checks that case). A kernel calling its plane function
    (``parallel_kernel`` -> slab) measured the same in every process; a plane function calling
    another is the pair to avoid: make the callee ``inline``. The scan finds the old pair."""
    import ast

    funcs = _compiled_on_their_own(repo_root)
    assert {"_lanczos_slab", "_galerkin_slab", "_jacobi2_zero_chunk", "ordered_sum"} <= set(funcs)
    pairs = sorted(
        f"{name} -> {call.func.id}"
        for name, node in funcs.items()
        for call in ast.walk(node)
        if isinstance(call, ast.Call)
        and isinstance(call.func, ast.Name)
        and call.func.id in funcs
        and call.func.id != name
    )
    assert pairs == []


def test_a_kernel_sum_is_the_serial_twins_on_two_threads() -> None:
    """Session 36 (see above): the float64 dot of a 4096-row float32 pair whose rows span 12
    decades, parallel twin against serial twin, bitwise, five calls (before: OpenMP's two
    partial sums, a different last bit)."""
    from solvers.voxel import kernels as kr

    if numba.get_num_threads() < 2:
        pytest.skip("one numba thread")
    rng = np.random.default_rng(36)
    scale = 10.0 ** rng.integers(-6, 7, (4096, 1))
    # three axes, as the multigrid passes its vectors (its 4096 rows of the last axis): a
    # two-axis pair compiled both twins for a type no solve passes (benchmarks/RESULTS.md,
    # session 40)
    a = (rng.standard_normal((4096, 16)) * scale).astype(np.float32).reshape(64, 64, 16)
    b = np.ones_like(a)
    serial = kr.dot.serial(a, b)
    assert serial == pytest.approx(np.sum(a, dtype=np.float64), rel=1e-12)
    assert [kr.dot.parallel(a, b) for _ in range(5)] == [serial] * 5


def test_numba_runs_on_openmp_unless_the_user_chose(tmp_path) -> None:
    """Session 36: numba takes TBB first where ``libtbb`` is installed (this machine got it with
    Debian's ``openfoam``); the thread policy was measured on OpenMP.  ``import psdesign`` puts
    OpenMP first, also after ``import numba``; a user's layer is kept."""
    code = (
        "import numba, psdesign, numpy as np\n"
        "f = numba.njit(parallel=True)(lambda a: a.sum())\n"
        "f(np.ones(8)); print(numba.threading_layer())\n"
    )
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_THREADING_LAYER")}
    try:
        from numba.np.ufunc import omppool  # noqa: F401
    except ImportError:
        pytest.skip("numba's OpenMP layer is not available here")
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert run.stdout.strip() == "omp", run.stderr[-500:]
    env["NUMBA_THREADING_LAYER"] = "workqueue"
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert run.stdout.strip() == "workqueue", run.stderr[-500:]


def _rods(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Four periodic rods of radius 0.12 n crossing a cube of ``n`` cells: solid and signed
    distance (cells; > 0 in the fluid)."""
    g = np.arange(n) + 0.5
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    dist = np.full((n, n, n), np.inf)
    for a, b, c0, c1 in [(x, y, 0.25, 0.3), (y, z, 0.7, 0.6), (z, x, 0.4, 0.8), (x, z, 0.8, 0.1)]:
        da = (a - c0 * n + n / 2) % n - n / 2
        db = (b - c1 * n + n / 2) % n - n / 2
        dist = np.minimum(dist, np.hypot(da, db) - 0.12 * n)
    return dist <= 0, dist


@pytest.mark.slow
@pytest.mark.parametrize("walls", ["staircase", "subvoxel"])
def test_a_solve_is_bitwise_the_same_on_one_and_two_threads(walls: str, monkeypatch) -> None:
    """Session 35's reproducibility audit: a 72^3 solve's true residual differed in its last bit
    between one and two threads (``residual_<d>`` of a study, ``error_estimate.solver``).  A
    374 k-cell grid (above ``SOLVE_PARALLEL_MIN_CELLS``) solved on one and on two threads: the
    residual history, iterations and mean velocity bitwise equal, the second solve on two."""
    from solvers import jit
    from solvers import voxel_stokes as vs

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one numba thread")
    monkeypatch.setattr(jit, "COMPILE_PARALLEL_ABOVE", 0)  # compile what a warm install runs
    solid, dist = _rods(72)
    distance = dist * 1e-6 if walls == "subvoxel" else None
    runs = []
    for threads in (1, 2):
        numba.set_num_threads(threads)
        try:
            res = vs.solve_voxel_stokes(solid, 1e-6, "z", tol=1e-6, distance=distance)
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        assert res.converged and res.threads_used == threads
        runs.append((res.history, res.iterations, res.residual, res.mean_velocity.tolist()))
    assert runs[0] == runs[1]


def _rule_probe(x):
    """The function of :func:`_probe` (never compiled)."""
    return x


def _probe(monkeypatch):
    """A :class:`solvers.jit.TwinKernel` whose parallel version is not compiled: it returns
    ``"parallel"`` where it would compile and run that version and ``"serial"`` where it runs
    its twin. numba's two threads are simulated (the solver's ``set_num_threads`` does
    nothing), so every decision is the compile rule's."""
    from solvers import jit

    monkeypatch.setattr(numba, "get_num_threads", lambda: 2)
    monkeypatch.setattr(numba, "set_num_threads", lambda n: None)
    monkeypatch.setattr(jit, "_PENDING", set())  # the probe's name stays out of the process's
    kern = jit.TwinKernel(_rule_probe)
    kern.parallel, kern.serial = (lambda x: "parallel"), (lambda x: "serial")
    kern._parallel_ready = lambda args: False
    return kern


def test_the_compile_rule_is_restored_when_a_solve_raises(monkeypatch) -> None:
    """Session 44 review3: the solve's compile rule holds inside the solve only; an exception
    inside it (here from the Krylov loop) must leave the process's rule as it was, or every
    later call of the process compiles or never compiles. With the rule at 100 cells the
    512-cell solve compiles; a 1-element call after it does not."""
    from solvers import jit
    from solvers import voxel_stokes as vs

    probe = _probe(monkeypatch)
    for kernel in _twin_kernels():
        monkeypatch.setattr(kernel, "parallel", kernel.serial)
    monkeypatch.setattr(jit, "COMPILE_PARALLEL_ABOVE", 100)
    seen = []

    def boom(*args, **kwargs):
        seen.append(probe(np.empty(1)))
        raise RuntimeError("inside the solve")

    monkeypatch.setattr(vs, "_solve_core", boom)
    solid = np.zeros((8, 8, 8), dtype=bool)
    solid[:, 2:5, 2:5] = True
    with pytest.raises(RuntimeError, match="inside the solve"):
        vs.solve_voxel_stokes(solid, 1e-6, "x", tol=1e-4)
    assert seen == ["parallel"]
    assert probe(np.empty(1)) == "serial" and jit.COMPILE_PARALLEL_ABOVE == 100


def _in_threads(*targets) -> None:
    """Run each target in its own thread; re-raise the first one's exception."""
    import threading

    errors: list[BaseException] = []

    def run(fn):
        try:
            fn()
        except BaseException as exc:  # noqa: BLE001 - handed to the test's thread
            errors.append(exc)

    threads = [threading.Thread(target=run, args=(fn,)) for fn in targets]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120)
    assert not any(t.is_alive() for t in threads), "a thread hung"
    if errors:
        raise errors[0]


def test_solves_in_two_threads_each_keep_their_own_compile_rule(monkeypatch) -> None:
    """Two solves in threads of one process (a dask worker started with ``--nthreads 2``, an
    API user's thread pool) whose ``_threads`` blocks interleave (a in, b in, a out, b out).
    Session 44 (review3) kept the rule a module global of ``solvers.jit`` that each block set:
    while both were open the later one's decision held for both, so the large grid ``a`` ran
    its serial twins once ``b`` was in (``solvers.jit`` session 45 reads each solve's cells
    from a ``ContextVar``). Each block decides by its own grid; the process's rule is as it
    was after both."""
    import threading

    from solvers import jit
    from solvers import voxel_stokes as vs

    probe = _probe(monkeypatch)
    rule = jit.COMPILE_PARALLEL_ABOVE
    monkeypatch.setattr(jit, "COMPILE_PARALLEL_ABOVE", rule)  # put back whatever happens
    a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()
    x = np.empty(1)
    seen: dict[str, list[str]] = {"a": [], "b": []}

    def a() -> None:  # a grid at the rule: compiles
        with vs._threads(rule):
            seen["a"].append(probe(x))
            a_in.set()
            assert b_in.wait(30)
            seen["a"].append(probe(x))  # b's block is open too
        a_out.set()

    def b() -> None:  # a grid below the rule, entering while a is inside and leaving after it
        assert a_in.wait(30)
        with vs._threads(rule - 1):
            b_in.set()
            seen["b"].append(probe(x))
            assert a_out.wait(30)
            seen["b"].append(probe(x))

    _in_threads(a, b)
    assert seen == {"a": ["parallel"] * 2, "b": ["serial"] * 2}
    assert probe(x) == "serial" and jit.COMPILE_PARALLEL_ABOVE == rule


def _rod(n: int) -> np.ndarray:
    """A square rod along x in a cube of ``n`` cells (flow along y)."""
    solid = np.zeros((n, n, n), dtype=bool)
    solid[:, n // 4 : n // 4 + n // 3, n // 4 : n // 4 + n // 3] = True
    return solid


def test_two_solves_overlapping_in_threads_each_report_their_own_kernels(monkeypatch) -> None:
    """As above with whole solves, held inside their solve blocks together (a barrier in front
    of the Krylov loop): a 16^3 grid above a rule of 3000 cells and a 12^3 grid below it. Each
    ran and reported its own rule (on session 44's code the later block's rule held for both,
    and both solves' kernels were logged in the later block's log: the large one said 1 of 2
    threads, or the small one 2), and each result is bitwise the one it gives alone. Two
    threads simulated, the parallel kernels' code is the serial twins' (as in
    :func:`test_a_solve_compiles_parallel_kernels_by_its_grid_cells`)."""
    import threading

    from solvers import jit
    from solvers import voxel_stokes as vs
    from solvers.voxel import threads as vthreads

    _probe(monkeypatch)
    monkeypatch.setattr(vthreads, "PARALLEL_MIN_CELLS", 0)
    monkeypatch.setattr(vthreads, "SOLVE_PARALLEL_MIN_CELLS", 0)
    monkeypatch.setattr(jit.TwinKernel, "_parallel_ready", lambda self, args: False)
    for kernel in _twin_kernels():
        monkeypatch.setattr(kernel, "parallel", kernel.serial)
    monkeypatch.setattr(jit, "COMPILE_PARALLEL_ABOVE", 3000)
    solids = {"large": _rod(16), "small": _rod(12)}

    def solve(name: str):
        return vs.solve_voxel_stokes(solids[name], 1e-6, "y", tol=1e-6)

    alone = {name: solve(name) for name in solids}
    core, together = vs._solve_core, threading.Barrier(2, timeout=60)

    def both_inside(*args, **kwargs):
        together.wait()
        return core(*args, **kwargs)

    monkeypatch.setattr(vs, "_solve_core", both_inside)
    res: dict = {}
    _in_threads(*[lambda n=name: res.__setitem__(n, solve(n)) for name in solids])
    large, small = res["large"], res["small"]
    assert (large.threads_used, large.thread_note, large.serial_fallback) == (2, "", ())
    assert small.threads_used == 1 and small.thread_note.startswith("ran on 1 of 2 threads")
    assert {"stokes_lanczos", "symmlq_step"} <= set(small.serial_fallback)
    for name, r in res.items():
        assert r.converged and alone[name].threads_used == r.threads_used
        assert (r.history, r.iterations) == (alone[name].history, alone[name].iterations)
        assert r.mean_velocity.tolist() == alone[name].mean_velocity.tolist()
