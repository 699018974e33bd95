"""The packing of a trace table's cubic pieces, written as explicit-SIMD LLVM IR.

:func:`pack_pieces` writes pieces ``1 .. count`` of one pulse's row of a
:class:`~sarmotion.imaging._bp_table.TraceTable` from that pulse's upsampled samples
``D_m`` and ``h D'_m`` (complex128, real and imaginary parts interleaved), :data:`WIDTH`
pieces at a time: piece ``p = m + 1`` runs from sample ``m`` to sample ``m + 1``,

    c0 = D_m,  c1 = h D'_m,
    c2 = (3 (D_{m+1} - D_m) - 2 h D'_m) - h D'_{m+1},
    c3 = (2 (D_m - D_{m+1}) + h D'_m) + h D'_{m+1},

each part evaluated in float64 in that order (no fused multiply-add), then rounded to
float32 and stored at float ``p`` of its plane (plane ``k`` of the row starts at float
``k length``; the planes are the real and imaginary parts of ``c0 .. c3``). These are the
values of the complex128 expressions of :func:`~sarmotion.imaging._bp_table.hermite_coefficients`:
there a real factor multiplies a complex number as ``(s + 0i)``, whose extra products
``0 x`` can change only the sign of a zero result.

Why IR and not a numba loop: the samples are interleaved and the eight planes are eight
stores into one row, so numba's loop stays scalar (LLVM cannot prove the row and the
samples apart); here the samples are loaded as vectors and split by shuffles. The IR is
generic LLVM (vector types only): on any CPU LLVM lowers it to that CPU's registers.
"""

from __future__ import annotations

from llvmlite import binding as llvm
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

__all__ = ["WIDTH", "pack_pieces"]

#: Pieces per step; ``count`` must be a multiple of it.
WIDTH = 8

_NAME = f"sarmotion_pack_pieces_v{WIDTH}"


def _build_ir(v: int = WIDTH) -> str:
    vd, vf, v2 = f"<{v} x double>", f"<{v} x float>", f"<{2 * v} x double>"
    even = ", ".join(f"i32 {2 * i}" for i in range(v))
    odd = ", ".join(f"i32 {2 * i + 1}" for i in range(v))
    lines: list[str] = []
    a = lines.append
    a(f"define weak_odr void @{_NAME}(ptr noalias %y, ptr noalias %d, ptr noalias %row,"
      " i64 %count, i64 %length) #0 {")  # fmt: skip
    a("entry:")
    a("  %empty = icmp sle i64 %count, 0")
    a("  br i1 %empty, label %done, label %loop")
    a("loop:")
    a("  %j = phi i64 [0, %entry], [%j.next, %loop]")
    a("  %k = shl i64 %j, 1")
    for name, src in (("y", "%y"), ("d", "%d")):
        a(f"  %{name}.p0 = getelementptr inbounds double, ptr {src}, i64 %k")
        a(f"  %{name}.p1 = getelementptr inbounds double, ptr %{name}.p0, i64 2")
        a(f"  %{name}.0 = load {v2}, ptr %{name}.p0, align 8")
        a(f"  %{name}.1 = load {v2}, ptr %{name}.p1, align 8")
        for part, idx in (("r", even), ("i", odd)):
            a(f"  %{name}{part} = shufflevector {v2} %{name}.0, {v2} poison, <{v} x i32> <{idx}>")
            a(f"  %{name}1{part} = shufflevector {v2} %{name}.1, {v2} poison,"
              f" <{v} x i32> <{idx}>")  # fmt: skip
    three = "splat (double 3.0)"
    two = "splat (double 2.0)"
    for part in ("r", "i"):
        a(f"  %x{part} = fsub {vd} %y1{part}, %y{part}")
        a(f"  %x3{part} = fmul {vd} {three}, %x{part}")
        a(f"  %b2{part} = fmul {vd} {two}, %d{part}")
        a(f"  %s{part} = fsub {vd} %x3{part}, %b2{part}")
        a(f"  %c2{part} = fsub {vd} %s{part}, %d1{part}")
        a(f"  %n{part} = fsub {vd} %y{part}, %y1{part}")
        a(f"  %n2{part} = fmul {vd} {two}, %n{part}")
        a(f"  %t{part} = fadd {vd} %n2{part}, %d{part}")
        a(f"  %c3{part} = fadd {vd} %t{part}, %d1{part}")
    planes = ("%yr", "%yi", "%dr", "%di", "%c2r", "%c2i", "%c3r", "%c3i")
    a("  %p = add i64 %j, 1")
    for q, value in enumerate(planes):
        a(f"  %f{q} = fptrunc {vd} {value} to {vf}")
        a(f"  %o{q}.b = mul i64 %length, {q}")
        a(f"  %o{q} = add i64 %o{q}.b, %p")
        a(f"  %ptr{q} = getelementptr inbounds float, ptr %row, i64 %o{q}")
        a(f"  store {vf} %f{q}, ptr %ptr{q}, align 4")
    a(f"  %j.next = add i64 %j, {v}")
    a("  %more = icmp slt i64 %j.next, %count")
    a("  br i1 %more, label %loop, label %done")
    a("done:")
    a("  ret void")
    a("}")
    a("attributes #0 = { noinline nounwind }")
    return "\n".join(lines) + "\n"


_IR = _build_ir()
llvm.parse_assembly(_IR).verify()  # fail at import, not inside a compilation


@intrinsic
def pack_pieces(typingctx, y, d, row, count, length):
    """Write pieces ``1 .. count`` of one table row (module docstring); compiled code only.

    ``y``, ``d``: float64, ``D`` and ``h D'`` of the pulse's samples, real and imaginary
    parts interleaved, at least ``2 count + 2`` floats (sample ``count`` is read as the
    last piece's end); ``row``: float32, eight planes of ``length`` floats; ``count`` a
    multiple of :data:`WIDTH`.
    """
    i = types.int64
    sig = types.void(y, d, row, i, i)

    def codegen(context, builder, signature, args):
        context.active_code_library.add_llvm_module(llvm.parse_assembly(_IR))
        byte_ptr = ir.IntType(8).as_pointer()
        i64 = ir.IntType(64)
        fnty = ir.FunctionType(ir.VoidType(), [byte_ptr] * 3 + [i64] * 2)
        fn = cgutils.get_or_insert_function(builder.module, fnty, _NAME)
        ptrs = [
            builder.bitcast(context.make_array(signature.args[k])(context, builder, args[k]).data,
                            byte_ptr)
            for k in range(3)
        ]  # fmt: skip
        builder.call(fn, ptrs + list(args[3:]))
        return context.get_dummy_value()

    return sig, codegen
