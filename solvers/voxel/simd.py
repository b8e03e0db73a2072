"""Vector instructions LLVM does not derive from a plain loop, as numba intrinsics.

``compress16``: the entries of 16 consecutive float32 values whose mask entry is non-zero, stored
contiguously (a compress into a register, ``vcompressps`` on AVX-512, and a whole-register store;
the 8-lane halves below otherwise).  LLVM does not vectorise the compress loop ``zc[c] =
zr[k]; c += m[k] != 0`` (each store address depends on the previous count): at 200^3 it took
2.4 ms per field against 0.84 ms for a plain copy, about 6 ms of CPU per Krylov iteration in
:func:`solvers.voxel.lanczos.symmlq_step` (``benchmarks/RESULTS.md``, vec10).

``prefetch_row``: software prefetch of a whole row (``llvm.prefetch``).  The row loops of the
multigrid smoothers and of the Lanczos product stalled on the first load of each row they
streamed from memory; prefetching the rows a few j ahead cut ``stokes_lanczos`` by 20 % and
``prolong_jacobi`` by 20 % of their one-thread CPU time at 200^3 (``benchmarks/RESULTS.md``,
band11).

``code_scale16``: the staircase pressure scales of 16 one-byte codes from 16 mantissas held in a
register (a permute) and an exponent add, bit-identical to the table look-up, which LLVM
compiled into a gather (a third of :func:`solvers.voxel.schur.pressure_block_code`'s time).

Both were written for AVX-512 (one ``vcompressps`` / ``vpermd`` on a 16-lane register).  Without
AVX-512 (e.g. AVX2 on Zen 3) LLVM lowers those 16-lane forms to scalar code: the compress to one
test, branch and store per lane, the permute to 16 loads from a stack copy of the table
(``code_scale16`` 3.0 ns and ``compress16`` 1.7 ns per entry in L2 on a Zen 3 core).  There they
are written as two 8-lane halves instead (:data:`WIDE`): the look-up as two 8-lane register
permutes and a blend by bit 3 of the index (``vpermd``, ``vblendvps``: 0.31 ns per entry), the
compress as an 8-lane permute by indices from a 256-entry table of the mask byte and a full
8-lane store (0.33 ns per entry); the same values (``benchmarks/RESULTS.md``, band18).
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.core.errors import TypingError
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic
from numba.np.arrayobj import populate_array

WIDTH = 16
"""Entries per :func:`compress16` call."""

HALF = 8
"""Lanes of the 256-bit halves of the forms without AVX-512."""

WIDE: bool | None = None
"""Lower :func:`compress16` and :func:`code_scale16` as 16-lane (AVX-512) forms (True) or as two
8-lane halves (False); None: as the target CPU of numba's code generator has ``avx512f`` or not.
Read when a calling function is compiled (the tests set it to compile both forms on one host;
numba's cache is keyed on the CPU and its features, so a cached kernel matches its host)."""


def _wide(context) -> bool:
    """:data:`WIDE`, or whether numba's target CPU has AVX-512 (``avx512f``)."""
    if WIDE is not None:
        return bool(WIDE)
    features = getattr(context.codegen(), "_tm_features", "") or ""
    return "+avx512f" in features.split(",")


def _half(builder, vec, h: int):
    """Lanes ``8 h .. 8 h + 7`` of a 16-lane vector."""
    lanes = ir.Constant(ir.VectorType(ir.IntType(32), HALF), [h * HALF + q for q in range(HALF)])
    return builder.shuffle_vector(vec, ir.Constant(vec.type, None), lanes)


def _permute(builder, src, idx):
    """``src[idx[l]]`` in lane ``l`` (``idx`` in range, any vector width): written lane by lane
    from the vector registers, which LLVM turns into one register permute where the CPU has one
    for the width (``vpermd`` / ``vpermps`` on AVX2 for 8 lanes, on AVX-512 for 16)."""
    i32 = ir.IntType(32)
    out = ir.Constant(src.type, None)
    for lane in range(idx.type.count):
        e = builder.extract_element(idx, ir.Constant(i32, lane))
        out = builder.insert_element(out, builder.extract_element(src, e), ir.Constant(i32, lane))
    return out


def _compress_table() -> list[int]:
    """For each 8-bit mask, the lanes of its set bits in order, 4 bits per lane (lane ``q`` of
    the packed vector in bits ``4 q .. 4 q + 2``)."""
    table = []
    for m in range(256):
        lanes = [q for q in range(HALF) if m >> q & 1]
        table.append(sum(lane << (4 * q) for q, lane in enumerate(lanes)))
    return table


_COMPRESS_TABLE = _compress_table()


@intrinsic
def compress16(typingctx, src, mask, dst, k, c):
    """``dst[c : c + n] = src[k : k + 16][mask[k : k + 16] != 0]``; returns ``n`` (int64).

    ``src``, ``dst``: 1-D contiguous float32 arrays; ``mask``: 1-D contiguous uint8 or float32;
    the caller keeps ``k + 16 <= len(src)`` and ``c + 16 <= len(dst)`` (no bounds checks; both
    forms store whole registers, so ``dst[c + n : c + 16]`` may be overwritten)."""
    for arr in (src, mask, dst):
        if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout in "CA"):
            raise TypingError("compress16 takes 1-D arrays")
    if src.dtype != types.float32 or dst.dtype != types.float32:
        raise TypingError("compress16 moves float32 entries")
    if mask.dtype not in (types.uint8, types.float32):
        raise TypingError("compress16 takes a uint8 or float32 mask")
    sig = types.int64(src, mask, dst, types.int64, types.int64)

    def codegen(context, builder, signature, args):
        src_v, mask_v, dst_v, k_v, c_v = args
        sa = context.make_array(signature.args[0])(context, builder, src_v)
        ma = context.make_array(signature.args[1])(context, builder, mask_v)
        da = context.make_array(signature.args[2])(context, builder, dst_v)
        byte = signature.args[1].dtype == types.uint8
        if _wide(context):
            return _compress_wide(builder, sa.data, ma.data, da.data, k_v, c_v, byte)
        return _compress_halves(builder, sa.data, ma.data, da.data, k_v, c_v, byte)

    return sig, codegen


def _active(builder, mp, lanes: int, byte: bool):
    """``mask[0 : lanes] != 0`` from the pointer ``mp`` (uint8 or float32 mask)."""
    if byte:
        vb = ir.VectorType(ir.IntType(8), lanes)
        mv = builder.load(builder.bitcast(mp, vb.as_pointer()), align=1)
        return builder.icmp_unsigned("!=", mv, ir.Constant(vb, None))
    vf = ir.VectorType(ir.FloatType(), lanes)
    mv = builder.load(builder.bitcast(mp, vf.as_pointer()), align=1)
    return builder.fcmp_unordered("!=", mv, ir.Constant(vf, None))


def _compress_wide(builder, src, mask, dst, k, c, byte: bool):
    """:func:`compress16` as a compress into a register (``llvm.x86.avx512.mask.compress``:
    ``vcompressps zmm{k}{z}, zmm``) and one full 16-lane store at the count so far.
    ``llvm.masked.compressstore`` (``vcompressps`` to memory) is microcoded on Zen 4: the gather
    of :func:`solvers.voxel.lanczos.symmlq_step` alone took 60 ms on one thread at 200^3 with
    it, 24 ms with this form (``benchmarks/RESULTS.md``, session 25)."""
    f32 = ir.FloatType()
    vf = ir.VectorType(f32, WIDTH)
    sv = builder.load(builder.bitcast(builder.gep(src, [k]), vf.as_pointer()), align=1)
    on = _active(builder, builder.gep(mask, [k]), WIDTH, byte)
    mod = builder.module
    # the x86 intrinsic, not llvm.experimental.vector.compress: that one needs LLVM >= 19
    # (llvmlite >= 0.45); this form is only compiled for an AVX-512 target
    compress_ty = ir.FunctionType(vf, [vf, vf, ir.VectorType(ir.IntType(1), WIDTH)])
    compress = cgutils.get_or_insert_function(
        mod, compress_ty, "llvm.x86.avx512.mask.compress.v16f32"
    )
    packed = builder.call(compress, [sv, ir.Constant(vf, None), on])
    builder.store(packed, builder.bitcast(builder.gep(dst, [c]), vf.as_pointer()), align=1)
    i16 = ir.IntType(16)
    popcnt = cgutils.get_or_insert_function(mod, ir.FunctionType(i16, [i16]), "llvm.ctpop.i16")
    return builder.zext(builder.call(popcnt, [builder.bitcast(on, i16)]), ir.IntType(64))


def _compress_halves(builder, src, mask, dst, k, c, byte: bool):
    """:func:`compress16` as two 8-lane halves: the mask byte picks the packed lanes' sources
    from :data:`_COMPRESS_TABLE`, one register permute packs them, a full 8-lane store writes
    them at the count so far."""
    i8, i32 = ir.IntType(8), ir.IntType(32)
    v8f = ir.VectorType(ir.FloatType(), HALF)
    v8i = ir.VectorType(i32, HALF)
    mod = builder.module
    table_ty = ir.ArrayType(i32, len(_COMPRESS_TABLE))
    table = cgutils.global_constant(
        mod, "psdesign_compress8_table", ir.Constant(table_ty, _COMPRESS_TABLE)
    )
    shifts = ir.Constant(v8i, [4 * q for q in range(HALF)])
    popcnt = cgutils.get_or_insert_function(mod, ir.FunctionType(i8, [i8]), "llvm.ctpop.i8")
    at = c
    for h in range(2):
        off = builder.add(k, ir.Constant(k.type, h * HALF))
        sv = builder.load(builder.bitcast(builder.gep(src, [off]), v8f.as_pointer()), align=1)
        bits = builder.bitcast(_active(builder, builder.gep(mask, [off]), HALF, byte), i8)
        entry = builder.load(builder.gep(table, [ir.Constant(i32, 0), builder.zext(bits, i32)]))
        idx = builder.and_(
            builder.lshr(_splat(builder, entry, HALF), shifts), ir.Constant(v8i, [7] * HALF)
        )
        out = builder.bitcast(builder.gep(dst, [at]), v8f.as_pointer())
        builder.store(_permute(builder, sv, idx), out, align=1)
        at = builder.add(at, builder.zext(builder.call(popcnt, [bits]), at.type))
    return builder.sub(at, c)


LINE = 64
"""Bytes per cache line (the stride of :func:`prefetch_row`)."""


@intrinsic
def prefetch_row(typingctx, row):
    """Ask the CPU to bring every cache line of the 1-D contiguous array ``row`` into its caches
    (``llvm.prefetch``, a read with high locality: ``prefetcht0`` on x86; no effect on the
    values, and no instruction on a target without one).  The multigrid's row loops call it a
    few rows ahead of the rows they are about to read from memory."""
    if not (isinstance(row, types.Array) and row.ndim == 1 and row.layout in "CA"):
        raise TypingError("prefetch_row takes a 1-D array")
    sig = types.void(row)

    def codegen(context, builder, signature, args):
        aty = signature.args[0]
        ary = context.make_array(aty)(context, builder, args[0])
        itemsize = context.get_constant(types.intp, aty.dtype.bitwidth // 8)
        nbytes = builder.mul(builder.extract_value(ary.shape, 0), itemsize)
        i8p = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        base = builder.bitcast(ary.data, i8p)
        fty = ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32])
        fn = cgutils.get_or_insert_function(builder.module, fty, "llvm.prefetch.p0i8")
        zero = context.get_constant(types.intp, 0)
        step = context.get_constant(types.intp, LINE)
        with cgutils.for_range_slice(builder, zero, nbytes, step) as (off, _):
            ptr = builder.gep(base, [off])
            builder.call(fn, [ptr, ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def prefetch_at(typingctx, arr, q):
    """Ask the CPU to bring the cache line holding element ``q`` of the 1-D contiguous array
    ``arr`` into its caches (``llvm.prefetch``, read, high locality).  ``q`` may lie past the
    end of ``arr``: a prefetch never faults, it only fetches nothing useful.  The flat Jacobi
    sweep (:func:`solvers.voxel.kernels.jacobi`) calls it once per 64 cells and stream, a few
    thousand bytes ahead of its loads."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout in "CA"):
        raise TypingError("prefetch_at takes a 1-D array")
    if not isinstance(q, types.Integer):
        raise TypingError("prefetch_at takes an integer index")
    sig = types.void(arr, q)

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        i8p = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        idx = context.cast(builder, args[1], signature.args[1], types.intp)
        ptr = builder.bitcast(builder.gep(ary.data, [idx]), i8p)
        fty = ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32])
        fn = cgutils.get_or_insert_function(builder.module, fty, "llvm.prefetch.p0i8")
        builder.call(fn, [ptr, ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def flat(typingctx, arr):
    """The C-contiguous array ``arr`` as a 1-D view of all its entries (``arr.reshape(-1)``
    without numba's run-time reshape call).  numba's ``reshape`` passes the new array's
    structure to a C helper (``numba_attempt_nocopy_reshape``), after which LLVM reloads the
    data pointer from memory and can no longer trace it to the kernel's argument: a
    ``noalias`` argument (:class:`solvers.jit.NoAliasCompiler`) then does not spare the
    vectorised loops their run-time overlap checks.  Here the view is built from the
    argument's own values (data pointer, meminfo, size), so the pointer stays the argument's."""
    if not (isinstance(arr, types.Array) and arr.layout == "C"):
        raise TypingError("flat takes a C-contiguous array")
    rty = arr.copy(ndim=1, layout="C")
    sig = rty(arr)

    def codegen(context, builder, signature, args):
        aty = signature.args[0]
        ary = context.make_array(aty)(context, builder, args[0])
        out = context.make_array(signature.return_type)(context, builder)
        populate_array(
            out, data=ary.data, shape=[ary.nitems], strides=[ary.itemsize],
            itemsize=ary.itemsize, meminfo=ary.meminfo, parent=ary.parent,
        )  # fmt: skip
        return impl_ret_borrowed(context, builder, signature.return_type, out._getvalue())

    return sig, codegen


@intrinsic
def code_scale16(typingctx, code, k, mant, shift, out):
    """``out[k : k + 16] = mant[c & 15] * 2^((c >> 4) + shift)`` for the 16 one-byte codes ``c =
    code[k : k + 16]``: the power of two is added to the float32 exponent bits, so the result is
    exactly the product (no rounding; the caller keeps it a normal float32).  The 16-entry
    look-up is written lane by lane on a vector register, which LLVM compiles into one register
    permute where the CPU has one (``vpermd`` with AVX-512) instead of a gather from memory;
    without AVX-512 (:data:`WIDE`) as two 8-lane permutes per half blended by bit 3 of the code.

    ``code``: 1-D contiguous uint8; ``mant``: 16 float32; ``out``: 1-D contiguous float32; the
    caller keeps ``k + 16 <= len(code)`` and ``len(out)`` (no bounds checks)."""
    for arr in (code, mant, out):
        if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout in "CA"):
            raise TypingError("code_scale16 takes 1-D arrays")
    if code.dtype != types.uint8 or mant.dtype != types.float32 or out.dtype != types.float32:
        raise TypingError("code_scale16 takes uint8 codes, float32 mantissas and output")
    sig = types.void(code, types.int64, mant, types.int64, out)

    def codegen(context, builder, signature, args):
        code_v, k_v, mant_v, shift_v, out_v = args
        ca = context.make_array(signature.args[0])(context, builder, code_v)
        ma = context.make_array(signature.args[2])(context, builder, mant_v)
        oa = context.make_array(signature.args[4])(context, builder, out_v)
        i32 = ir.IntType(32)
        f32 = ir.FloatType()
        vi8 = ir.VectorType(ir.IntType(8), WIDTH)
        vi32 = ir.VectorType(i32, WIDTH)
        vf = ir.VectorType(f32, WIDTH)
        cp = builder.bitcast(builder.gep(ca.data, [k_v]), vi8.as_pointer())
        c = builder.zext(builder.load(cp, align=1), vi32)
        idx = builder.and_(c, ir.Constant(vi32, [15] * WIDTH))
        table = builder.load(builder.bitcast(ma.data, vf.as_pointer()), align=1)
        if _wide(context):  # lane l takes table[idx[l]]: one vpermd on AVX-512
            val = _permute(builder, table, idx)
        else:  # two 8-lane permutes per half, blended by bit 3 of the index
            v8 = ir.VectorType(i32, HALF)
            lo, hi = _half(builder, table, 0), _half(builder, table, 1)
            halves = []
            for h in range(2):
                ih = _half(builder, idx, h)
                i7 = builder.and_(ih, ir.Constant(v8, [7] * HALF))
                up = builder.and_(ih, ir.Constant(v8, [HALF] * HALF))
                upper = builder.icmp_unsigned("!=", up, ir.Constant(v8, None))
                pick = builder.select(upper, _permute(builder, hi, i7), _permute(builder, lo, i7))
                halves.append(pick)
            whole = ir.Constant(vi32, list(range(WIDTH)))
            val = builder.shuffle_vector(halves[0], halves[1], whole)
        sh = builder.trunc(shift_v, i32)
        expo = builder.add(builder.lshr(c, ir.Constant(vi32, [4] * WIDTH)), _splat(builder, sh))
        bits = builder.add(
            builder.bitcast(val, vi32), builder.shl(expo, ir.Constant(vi32, [23] * WIDTH))
        )
        op = builder.bitcast(builder.gep(oa.data, [k_v]), vf.as_pointer())
        builder.store(builder.bitcast(bits, vf), op, align=1)
        return context.get_dummy_value()

    return sig, codegen


def _splat(builder, scalar, lanes: int = WIDTH):
    """A vector of ``lanes`` copies of an i32 ``scalar``."""
    vty = ir.VectorType(scalar.type, lanes)
    one = builder.insert_element(ir.Constant(vty, None), scalar, ir.Constant(ir.IntType(32), 0))
    return builder.shuffle_vector(one, ir.Constant(vty, None), ir.Constant(vty, [0] * lanes))
