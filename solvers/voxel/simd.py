"""Vector instructions LLVM does not derive from a plain loop, as numba intrinsics.

``compress16``: the entries of 16 consecutive float32 values whose mask entry is non-zero, stored
contiguously (``llvm.masked.compressstore``: one AVX-512 ``vcompressps`` where the CPU has it,
scalar code that LLVM writes otherwise).  LLVM does not vectorise the compress loop ``zc[c] =
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
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.core.errors import TypingError
from numba.extending import intrinsic

WIDTH = 16
"""Entries per :func:`compress16` call."""


@intrinsic
def compress16(typingctx, src, mask, dst, k, c):
    """``dst[c : c + n] = src[k : k + 16][mask[k : k + 16] != 0]``; returns ``n`` (int64).

    ``src``, ``dst``: 1-D contiguous float32 arrays; ``mask``: 1-D contiguous uint8 or float32;
    the caller keeps ``k + 16 <= len(src)`` and ``c + n <= len(dst)`` (no bounds checks)."""
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
        f32 = ir.FloatType()
        vf = ir.VectorType(f32, WIDTH)
        sv = builder.load(builder.bitcast(builder.gep(sa.data, [k_v]), vf.as_pointer()), align=1)
        mp = builder.gep(ma.data, [k_v])
        if signature.args[1].dtype == types.uint8:
            vb = ir.VectorType(ir.IntType(8), WIDTH)
            mv = builder.load(builder.bitcast(mp, vb.as_pointer()), align=1)
            on = builder.icmp_unsigned("!=", mv, ir.Constant(vb, None))
        else:
            mv = builder.load(builder.bitcast(mp, vf.as_pointer()), align=1)
            on = builder.fcmp_unordered("!=", mv, ir.Constant(vf, None))
        mod = builder.module
        store_ty = ir.FunctionType(
            ir.VoidType(), [vf, f32.as_pointer(), ir.VectorType(ir.IntType(1), WIDTH)]
        )
        store = cgutils.get_or_insert_function(mod, store_ty, "llvm.masked.compressstore.v16f32")
        builder.call(store, [sv, builder.gep(da.data, [c_v]), on])
        i16 = ir.IntType(16)
        popcnt = cgutils.get_or_insert_function(mod, ir.FunctionType(i16, [i16]), "llvm.ctpop.i16")
        return builder.zext(builder.call(popcnt, [builder.bitcast(on, i16)]), ir.IntType(64))

    return sig, codegen


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
def code_scale16(typingctx, code, k, mant, shift, out):
    """``out[k : k + 16] = mant[c & 15] * 2^((c >> 4) + shift)`` for the 16 one-byte codes ``c =
    code[k : k + 16]``: the power of two is added to the float32 exponent bits, so the result is
    exactly the product (no rounding; the caller keeps it a normal float32).  The 16-entry
    look-up is written lane by lane on a vector register, which LLVM compiles into one register
    permute where the CPU has one (``vpermd`` with AVX-512) instead of a gather from memory.

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
        # lane l takes table[idx[l]]: LLVM turns this into one register permute (vpermd on
        # AVX-512) instead of a gather from memory
        val = ir.Constant(vf, None)
        for lane in range(WIDTH):
            e = builder.extract_element(idx, ir.Constant(i32, lane))
            val = builder.insert_element(
                val, builder.extract_element(table, e), ir.Constant(i32, lane)
            )
        sh = builder.trunc(shift_v, i32)
        expo = builder.add(builder.lshr(c, ir.Constant(vi32, [4] * WIDTH)), _splat(builder, sh))
        bits = builder.add(
            builder.bitcast(val, vi32), builder.shl(expo, ir.Constant(vi32, [23] * WIDTH))
        )
        op = builder.bitcast(builder.gep(oa.data, [k_v]), vf.as_pointer())
        builder.store(builder.bitcast(bits, vf), op, align=1)
        return context.get_dummy_value()

    return sig, codegen


def _splat(builder, scalar):
    """A vector of :data:`WIDTH` copies of an i32 ``scalar``."""
    vty = ir.VectorType(scalar.type, WIDTH)
    one = builder.insert_element(ir.Constant(vty, None), scalar, ir.Constant(ir.IntType(32), 0))
    return builder.shuffle_vector(one, ir.Constant(vty, None), ir.Constant(vty, [0] * WIDTH))
