"""The inner loop of the compiled backprojection kernel, written as explicit-SIMD LLVM IR.

One call adds one pulse to one image tile: for every pixel of ``n_rows`` rows of ``n``
pixels (``n`` a multiple of :data:`LANES`) it evaluates, ``LANES`` pixels at a time,

    N      = Nx[k] + Ny[r]                                    (float32, m^2)
    nl     = N^2 (a2 + N (a3 + N a4))                         (range series beyond linear, m)
    delta  = a1 N + nl                                        (range offset from the anchor, m)
    q      = f0 + delta si ;  i = floor(q) ;  w = q - i         (fast-time table position)
    v      = c0 + w (c1 + w (c2 + w c3))                       (cubic piece i0 + i, complex)
    T      = Tx[k] + Ty[r] + nl sq                             (carrier phase, quarter cycles)
    acc   += v exp(i pi T / 2)

``Tx``, ``Ty`` carry the anchor's phase and the phase of the linear term ``a1 N``, formed in
float64 and reduced to ``[-2, 2)`` by the caller (:func:`tile_pulses`), so only ``nl sq``
(a few quarter cycles) is float32. ``tab`` holds the pulse's cubic pieces
(:class:`~sarmotion.imaging._bp_table.TraceTable`) in eight float32 planes (the real and
imaginary parts of ``c0 .. c3``), so the lanes' entries of one plane arrive in one vector
without de-interleaving. Where they lie within a window (neighbouring pixels read
neighbouring entries: the usual case, see :func:`~sarmotion.imaging._bp_kernels.lane_spans`)
the table is read without gathers, by the instruction set numba compiles for (:data:`ISA`):

- AVX-512: a window of ``2 LANES`` entries, two vector loads and one two-source permute
  (``vpermt2ps``) per plane;
- AVX2: per 8 lanes a window of 8 entries, one load and one ``vpermps`` per plane (two per
  plane and step: a step's 16 lanes are two 256-bit halves);

otherwise, and on other CPUs, one gather per plane. Positions outside ``[1, hi)`` read
entry 0 (zero) with ``w = 0``. Where :func:`tile_pulses` has shown, for a whole pulse and
tile, that every step's lanes lie in their window and every position in ``[1, hi)``
(:func:`lanes_in_window`), a second variant runs without these checks and without the
gathers behind them.
``exp(i pi T / 2)`` is ``i^k exp(i pi (T - k) / 2)``, ``k = rint(T)``, with minimax
polynomials on ``|T - k| <= 1/2`` (sine: 3 terms, error 5.7e-7; cosine: 4 terms, 5.4e-8).

Why IR and not a numba loop: numba's auto-vectoriser gives 8-lane loops with 64-bit-index
gathers; this loop is written for 16 lanes and reads the table by windows. Without AVX-512
or AVX2 the IR is generic LLVM (vector types, ``llvm.masked.gather``): on a CPU without
gathers or wide registers LLVM splits or scalarises it, and the result is the same. (LLVM
scalarises the gathers also on AVX2 CPUs whose gathers it deems slow, Haswell and AMD's
Zen among them: there the windows matter most.)

The function is linked into each numba function that calls :func:`tile_pulse` (weak ODR
linkage, so copies merge) and is not inlined, so its ``prefer-vector-width`` attribute
holds.
"""

from __future__ import annotations

import math
import re

import numba
import numpy as np
from llvmlite import binding as llvm
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

__all__ = ["LANES", "WINDOW_SPAN", "lanes_in_window", "tile_pulse", "tile_pulses"]

#: Pixels per SIMD step; tile rows are padded to a multiple of it.
LANES = 16

# float32 minimax coefficients of sin(pi r / 2) / r and cos(pi r / 2) in r^2, |r| <= 1/2.
_SIN = (1.5707885026931763, -0.6457120180130005, 0.07766739279031754)
_COS = (1.0, -1.2336970567703247, 0.2535986304283142, -0.020408352836966515)


def _target() -> tuple[str, str]:
    """The CPU name and feature string numba compiles for (as its JIT code generator)."""
    from numba.core.codegen import get_host_cpu_features

    name = numba.config.CPU_NAME or llvm.get_host_cpu_name()
    features = numba.config.CPU_FEATURES
    if features is None:
        features = get_host_cpu_features()
    return name, features


def _target_isa() -> str | None:
    """The table read numba's target supports: ``"avx512"``, ``"avx2"`` or ``None``.

    Asked of LLVM itself, for the CPU name and features numba compiles for
    (``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES`` when set, else the host's): a 16-float add
    lowered to one ``zmm`` instruction means AVX-512F, an 8-integer add to one ``ymm``
    instruction AVX2. So ``NUMBA_CPU_NAME=haswell NUMBA_CPU_FEATURES=""`` (the features
    LLVM knows for Haswell) selects the AVX2 read on any x86 host, while
    ``NUMBA_CPU_NAME=haswell`` alone keeps the host's features, AVX-512 included.
    """
    name, features = _target()
    if not llvm.get_process_triple().startswith(("x86_64", "i686", "i386")):
        return None
    llvm.initialize_native_target()
    llvm.initialize_native_asmprinter()
    probe = (
        "define <16 x float> @f(<16 x float> %a, <16 x float> %b) #0 {\n"
        "  %c = fadd <16 x float> %a, %b\n  ret <16 x float> %c\n}\n"
        "define <8 x i32> @i(<8 x i32> %a, <8 x i32> %b) {\n"
        "  %c = add <8 x i32> %a, %b\n  ret <8 x i32> %c\n}\n"
        'attributes #0 = { "prefer-vector-width"="512" "min-legal-vector-width"="512" }\n'
    )
    try:
        tm = llvm.Target.from_default_triple().create_target_machine(
            cpu=name, features=features, opt=0
        )
        asm = tm.emit_assembly(llvm.parse_assembly(probe))
    except RuntimeError:  # an unknown CPU name or feature: assume the least
        return None
    if re.search(r"vaddps\s+%zmm", asm):
        return "avx512"
    if re.search(r"vpaddd\s+%ymm", asm):
        return "avx2"
    return None


#: The instruction set the inner loop reads the table's windows with: ``"avx512"`` (one
#: two-source permute of 32 entries per plane), ``"avx2"`` (per 8 lanes, one load and one
#: ``vpermps`` of 8 entries per plane) or ``None`` (gathers alone: generic IR).
ISA = _target_isa() if LANES == 16 else None

#: Whether the inner loop reads windows of the table with AVX-512 permutes.
PERMUTE = ISA == "avx512"

#: Entries of one AVX2 window (one ``vpermps``), and the lanes that share it.
_AVX2_WINDOW = 8


def _function_name(v: int, isa: str | None, checked: bool) -> str:
    if not checked:
        return f"sarmotion_bp_tile_pulse_v{v}_f32planes_windowed_{isa}"
    return f"sarmotion_bp_tile_pulse_v{v}_f32planes{'_window_' + isa if isa else ''}"


#: Change ``SIMD_VERSION`` in :mod:`._bp_kernels` and :mod:`._ffbp_kernels` with this IR
#: (numba's cache of their kernels does not see this file).
_NAME = _function_name(LANES, ISA, True)
#: The variant without the per-step window check (AVX-512 and AVX2), for a pulse whose
#: lanes :func:`tile_pulses` has shown to lie in the window at every step.
_NAME_WINDOWED = _function_name(LANES, ISA, False)

#: Most table entries the lanes of one step may span for the unchecked variant: the window
#: starts 4 entries below the smaller end lane's entry and holds ``2 LANES``, so lanes
#: within ``V`` entries of each other (their floors within ``V + 1``) lie inside it when
#: ``V + 1 <= 4`` (below) and ``4 + V + 1 < 2 LANES`` (above). The AVX2 read's window
#: starts 3 entries below the smaller end lane's entry of each eight lanes and holds 8:
#: eight lanes span 7 of a step's ``LANES - 1`` pixel intervals, so their floors lie within
#: ``7 V / 15 + 1 < 3`` entries of each other, at most 2 below or above either end lane.
WINDOW_SPAN = 3.0
#: The table's planes, in order (:class:`~sarmotion.imaging._bp_table.TraceTable`).
_PLANES = ("c0re", "c0im", "c1re", "c1im", "c2re", "c2im", "c3re", "c3im")


def _f32(x: float) -> str:
    """An LLVM ``float`` literal: the float32 value written as a double in hex."""
    return f"0x{int(np.array(np.float32(x), np.float64).view(np.uint64)):016X}"


def _build_ir(v: int = LANES, isa: str | None = None, checked: bool = True) -> str:
    """The inner loop's IR (one function).

    ``isa`` ``"avx512"``: the table read by windows of ``2 v`` entries with two-source
    permutes; ``"avx2"``: by windows of 8 entries per 8 lanes with ``vpermps``; ``None``:
    gathers alone. ``checked`` keeps each step's check that its lanes lie in their windows
    (else gathers), the other variant (``isa`` set) has neither check nor gathers.
    """
    if isa not in (None, "avx512", "avx2"):
        raise ValueError(f"unknown instruction set {isa!r}")
    if isa == "avx512" and v != 16 or isa == "avx2" and v not in (8, 16):
        raise ValueError(f"{isa} windows need {'16' if isa == 'avx512' else '8 or 16'} lanes")
    permute = isa is not None
    vf, vi, vp, vb = f"<{v} x float>", f"<{v} x i32>", f"<{v} x ptr>", f"<{v} x i1>"
    fma = f"@llvm.fmuladd.v{v}f32"
    lines: list[str] = []
    a = lines.append

    def horner(name: str, coeffs: tuple[float, ...]) -> str:
        acc = f"splat (float {_f32(coeffs[-1])})"
        for i, c in enumerate(coeffs[-2::-1]):
            coeff = f"splat (float {_f32(c)})"
            a(f"  %{name}{i} = call fast {vf} {fma}({vf} %z, {vf} {acc}, {vf} {coeff})")
            acc = f"%{name}{i}"
        return acc

    scalars = ["f0", "i0f", "a1", "a2", "a3", "a4", "si", "sq", "hi"]
    name = _function_name(v, isa, checked)
    a(f"define weak_odr void @{name}(ptr noalias %nx, ptr noalias %ny, ptr noalias %tx,"
      " ptr noalias %ty, ptr noalias %tab,"
      " ptr noalias %acc_re, ptr noalias %acc_im, i64 %n, i64 %n_rows, i64 %stride, i64 %plane, "
      + ", ".join(f"float %{s}" for s in scalars) + ") #0 {")  # fmt: skip
    a("entry:")
    for p in range(len(_PLANES)):
        a(f"  %pl{p} = mul i64 %plane, {p}")
    for s in scalars:
        a(f"  %{s}.i = insertelement {vf} poison, float %{s}, i64 0")
        a(f"  %{s}.v = shufflevector {vf} %{s}.i, {vf} poison, {vi} zeroinitializer")
    a("  br label %row")
    a("row:")
    a("  %r = phi i64 [0, %entry], [%r.next, %row.end]")
    a("  %ny.p = getelementptr inbounds float, ptr %ny, i64 %r")
    a("  %nyr = load float, ptr %ny.p, align 4")
    a(f"  %nyr.i = insertelement {vf} poison, float %nyr, i64 0")
    a(f"  %nyr.v = shufflevector {vf} %nyr.i, {vf} poison, {vi} zeroinitializer")
    a("  %ty.p = getelementptr inbounds float, ptr %ty, i64 %r")
    a("  %tyr = load float, ptr %ty.p, align 4")
    a(f"  %tyr.i = insertelement {vf} poison, float %tyr, i64 0")
    a(f"  %tyr.v = shufflevector {vf} %tyr.i, {vf} poison, {vi} zeroinitializer")
    a("  %off = mul i64 %r, %stride")
    a("  %row.re = getelementptr inbounds float, ptr %acc_re, i64 %off")
    a("  %row.im = getelementptr inbounds float, ptr %acc_im, i64 %off")
    a("  br label %px")
    a("px:")
    a(f"  %k = phi i64 [0, %row], [%k.next, %{'got' if permute and checked else 'px'}]")
    a("  %nx.p = getelementptr inbounds float, ptr %nx, i64 %k")
    a(f"  %nxk = load {vf}, ptr %nx.p, align 4")
    a(f"  %N = fadd fast {vf} %nxk, %nyr.v")
    a(f"  %h3 = call fast {vf} {fma}({vf} %N, {vf} %a4.v, {vf} %a3.v)")
    a(f"  %h2 = call fast {vf} {fma}({vf} %N, {vf} %h3, {vf} %a2.v)")
    a(f"  %N2 = fmul fast {vf} %N, %N")
    a(f"  %nl = fmul fast {vf} %N2, %h2")  # the range offset less its part linear in N
    a(f"  %dl = call fast {vf} {fma}({vf} %N, {vf} %a1.v, {vf} %nl)")
    a("  %tx.p = getelementptr inbounds float, ptr %tx, i64 %k")
    a(f"  %txk = load {vf}, ptr %tx.p, align 4")
    a(f"  %txy = fadd fast {vf} %txk, %tyr.v")
    a(f"  %q = call fast {vf} {fma}({vf} %dl, {vf} %si.v, {vf} %f0.v)")
    a(f"  %fl = call fast {vf} @llvm.floor.v{v}f32({vf} %q)")
    a(f"  %w = fsub fast {vf} %q, %fl")
    a(f"  %fa = fadd fast {vf} %fl, %i0f.v")
    if checked:
        a(f"  %ok.lo = fcmp fast oge {vf} %fa, splat (float {_f32(1.0)})")
        a(f"  %ok.hi = fcmp fast olt {vf} %fa, %hi.v")
        a(f"  %ok = and {vb} %ok.lo, %ok.hi")
        a(f"  %ix0 = fptosi {vf} %fa to {vi}")
        a(f"  %ix = select {vb} %ok, {vi} %ix0, {vi} zeroinitializer")
        a(f"  %wk = select {vb} %ok, {vf} %w, {vf} zeroinitializer")
    else:  # every position in [1, hi): lanes_in_window's bounds
        a(f"  %ix = fptosi {vf} %fa to {vi}")
        a(f"  %wk = fadd {vf} %w, splat (float -0.0)")  # the same value: x + (-0) = x
    gather = f"@llvm.masked.gather.v{v}f32.v{v}p0"
    if isa == "avx512":
        # The lanes' entries within a window of 2 v entries (the usual case): two vector
        # loads and one two-source permute per plane, no gather. The window starts 4
        # entries before the smaller of the end lanes' entries (a row of pixels reads
        # monotone or nearly monotone entries), at entry 0 at the least.
        window = 2 * v  # entries a two-source permute reaches
        groups = [(0, v, 4)]
    elif isa == "avx2":
        # Per 8 lanes a window of 8 entries, 3 before the smaller of those lanes' end
        # entries: one load and one vpermps (within 8 entries) per plane and 8 lanes.
        window = _AVX2_WINDOW
        groups = [(g, g + window, 3) for g in range(0, v, window)]
    if permute:
        for g, (l0, l1, margin) in enumerate(groups):
            a(f"  %ia{g} = extractelement {vi} %ix, i64 {l0}")
            a(f"  %ib{g} = extractelement {vi} %ix, i64 {l1 - 1}")
            a(f"  %ab{g} = icmp slt i32 %ia{g}, %ib{g}")
            a(f"  %iab{g} = select i1 %ab{g}, i32 %ia{g}, i32 %ib{g}")
            a(f"  %wlo{g} = sub i32 %iab{g}, {margin}")
            a(f"  %mpos{g} = icmp sgt i32 %wlo{g}, 0")
            a(f"  %mn{g} = select i1 %mpos{g}, i32 %wlo{g}, i32 0")
        # every lane's window start, as a vector
        if len(groups) == 1:
            a(f"  %mn.i = insertelement {vi} poison, i32 %mn0, i64 0")
            a(f"  %mn.v = shufflevector {vi} %mn.i, {vi} poison, {vi} zeroinitializer")
        else:
            a(f"  %mn.v.0 = insertelement {vi} poison, i32 %mn0, i64 0")
            for g in range(1, len(groups)):
                a(f"  %mn.v.{g} = insertelement {vi} %mn.v.{g - 1}, i32 %mn{g}, i64 {g}")
            lanes = ", ".join(f"i32 {k // window}" for k in range(v))
            a(f"  %mn.v = shufflevector {vi} %mn.v.{len(groups) - 1}, {vi} poison,"
              f" <{v} x i32> <{lanes}>")  # fmt: skip
        a(f"  %rel = sub {vi} %ix, %mn.v")
        if checked:
            a(f"  %inw = icmp ult {vi} %rel, splat (i32 {window})")
            a(f"  %narrow = call i1 @llvm.vector.reduce.and.v{v}i1({vb} %inw)")
            a("  br i1 %narrow, label %win, label %gat")
            a("win:")
        for g in range(len(groups)):
            a(f"  %mn64.{g} = sext i32 %mn{g} to i64")
        if isa == "avx2":
            w8f, w8i = f"<{window} x float>", f"<{window} x i32>"
            for g, (l0, l1, _) in enumerate(groups):
                lanes = ", ".join(f"i32 {k}" for k in range(l0, l1))
                a(f"  %rel{g} = shufflevector {vi} %rel, {vi} poison, {w8i} <{lanes}>")
        for p, name in enumerate(_PLANES):
            target = f"%w{name}" if checked else f"%{name}"
            if isa == "avx512":
                a(f"  %w{name}.o = add i64 %mn64.0, %pl{p}")
                a(f"  %w{name}.p0 = getelementptr inbounds float, ptr %tab, i64 %w{name}.o")
                a(f"  %w{name}.p1 = getelementptr inbounds float, ptr %w{name}.p0, i64 {v}")
                a(f"  %w{name}.0 = load {vf}, ptr %w{name}.p0, align 4")
                a(f"  %w{name}.1 = load {vf}, ptr %w{name}.p1, align 4")
                a(
                    f"  {target} = call {vf} @llvm.x86.avx512.vpermi2var.ps.512({vf} %w{name}.0,"
                    f" {vi} %rel, {vf} %w{name}.1)"
                )
                continue
            for g in range(len(groups)):
                out = target if len(groups) == 1 else f"%w{name}.{g}"
                a(f"  %w{name}.o{g} = add i64 %mn64.{g}, %pl{p}")
                a(f"  %w{name}.p{g} = getelementptr inbounds float, ptr %tab, i64 %w{name}.o{g}")
                a(f"  %w{name}.l{g} = load {w8f}, ptr %w{name}.p{g}, align 4")
                a(f"  {out} = call {w8f} @llvm.x86.avx2.permps({w8f} %w{name}.l{g},"
                  f" {w8i} %rel{g})")  # fmt: skip
            if len(groups) == 2:  # the two halves' vectors, concatenated
                lanes = ", ".join(f"i32 {k}" for k in range(v))
                a(f"  {target} = shufflevector {w8f} %w{name}.0, {w8f} %w{name}.1,"
                  f" {vi} <{lanes}>")  # fmt: skip
        if checked:
            a("  br label %got")
            a("gat:")
    if checked:
        a(f"  %pbase = getelementptr inbounds float, ptr %tab, {vi} %ix")
        for p, name in enumerate(_PLANES):
            a(f"  %p{name} = getelementptr inbounds float, {vp} %pbase, i64 %pl{p}")
            target = f"%q{name}" if permute else f"%{name}"
            a(
                f"  {target} = call {vf} {gather}({vp} %p{name}, i32 4, {vb} splat (i1 true),"
                f" {vf} poison)"
            )
    if permute and checked:
        a("  br label %got")
        a("got:")
        for name in _PLANES:
            a(f"  %{name} = phi {vf} [%w{name}, %win], [%q{name}, %gat]")
    for part in ("re", "im"):
        a(f"  %h2{part} = call fast {vf} {fma}({vf} %wk, {vf} %c3{part}, {vf} %c2{part})")
        a(f"  %h1{part} = call fast {vf} {fma}({vf} %wk, {vf} %h2{part}, {vf} %c1{part})")
        a(f"  %v{part} = call fast {vf} {fma}({vf} %wk, {vf} %h1{part}, {vf} %c0{part})")
    a(f"  %T = call fast {vf} {fma}({vf} %nl, {vf} %sq.v, {vf} %txy)")
    a(f"  %kq = call fast {vf} @llvm.rint.v{v}f32({vf} %T)")
    a(f"  %x = fsub fast {vf} %T, %kq")
    a(f"  %z = fmul fast {vf} %x, %x")
    ps = horner("ps", _SIN)
    a(f"  %s = fmul fast {vf} %x, {ps}")
    pc = horner("pc", _COS)
    # exp(i pi T / 2) = i^k (c + i s): odd k swaps (c, s) -> (-s, c); k & 2 negates both.
    a(f"  %ki = fptosi {vf} %kq to {vi}")
    a(f"  %k1 = and {vi} %ki, splat (i32 1)")
    a(f"  %swap = icmp ne {vi} %k1, zeroinitializer")
    a(f"  %sneg = fneg fast {vf} %s")
    a(f"  %c1 = select {vb} %swap, {vf} %sneg, {vf} {pc}")
    a(f"  %s1 = select {vb} %swap, {vf} {pc}, {vf} %s")
    a(f"  %k2 = and {vi} %ki, splat (i32 2)")
    a(f"  %sign = shl {vi} %k2, splat (i32 30)")
    a(f"  %c1b = bitcast {vf} %c1 to {vi}")
    a(f"  %s1b = bitcast {vf} %s1 to {vi}")
    a(f"  %c2b = xor {vi} %c1b, %sign")
    a(f"  %s2b = xor {vi} %s1b, %sign")
    a(f"  %cs = bitcast {vi} %c2b to {vf}")
    a(f"  %sn = bitcast {vi} %s2b to {vf}")
    a("  %are.p = getelementptr inbounds float, ptr %row.re, i64 %k")
    a("  %aim.p = getelementptr inbounds float, ptr %row.im, i64 %k")
    a(f"  %xre = load {vf}, ptr %are.p, align 4")
    a(f"  %xim = load {vf}, ptr %aim.p, align 4")
    a(f"  %m1 = fmul fast {vf} %vim, %sn")
    a(f"  %m2 = fsub fast {vf} %xre, %m1")
    a(f"  %yre = call fast {vf} {fma}({vf} %vre, {vf} %cs, {vf} %m2)")
    a(f"  %m3 = call fast {vf} {fma}({vf} %vre, {vf} %sn, {vf} %xim)")
    a(f"  %yim = call fast {vf} {fma}({vf} %vim, {vf} %cs, {vf} %m3)")
    a(f"  store {vf} %yre, ptr %are.p, align 4")
    a(f"  store {vf} %yim, ptr %aim.p, align 4")
    a(f"  %k.next = add i64 %k, {v}")
    a("  %more = icmp slt i64 %k.next, %n")
    a("  br i1 %more, label %px, label %row.end")
    a("row.end:")
    a("  %r.next = add i64 %r, 1")
    a("  %rows = icmp slt i64 %r.next, %n_rows")
    a("  br i1 %rows, label %row, label %done")
    a("done:")
    a("  ret void")
    a("}")
    a(f"declare {vf} {fma}({vf}, {vf}, {vf})")
    a(f"declare {vf} @llvm.floor.v{v}f32({vf})")
    a(f"declare {vf} @llvm.rint.v{v}f32({vf})")
    a(f"declare {vf} {gather}({vp}, i32, {vb}, {vf})")
    if permute:
        a(f"declare i1 @llvm.vector.reduce.and.v{v}i1({vb})")
    if isa == "avx512":
        a(f"declare {vf} @llvm.x86.avx512.vpermi2var.ps.512({vf}, {vi}, {vf})")
    if isa == "avx2":
        a("declare <8 x float> @llvm.x86.avx2.permps(<8 x float>, <8 x i32>)")
    width = 32 * v
    a(f'attributes #0 = {{ noinline nounwind "prefer-vector-width"="{width}" '
      f'"min-legal-vector-width"="{width}" }}')  # fmt: skip
    return "\n".join(lines) + "\n"


_IR = _build_ir(LANES, isa=ISA)
if ISA:  # both variants in one module; the declarations once
    _unchecked = _build_ir(LANES, isa=ISA, checked=False)
    _IR += _unchecked[: _unchecked.index("\ndeclare ")] + "\n"
llvm.parse_assembly(_IR).verify()  # fail at import, not inside a compilation


@intrinsic
def tile_pulse(
    typingctx, nx, ny, tx, ty, tab, tab_offset, acc_re, acc_im, n, n_rows, stride, plane,
    f0, i0f, a1, a2, a3, a4, si, sq, hi, windowed,
):  # fmt: skip
    """Add one pulse to one tile (see the module docstring); compiled code only.

    ``nx``, ``tx`` (float32, >= n), ``ny``, ``ty`` (float32, >= n_rows), ``tab`` (the float32
    table, the pulse's entries starting at flat index ``tab_offset``), ``acc_re`` /
    ``acc_im`` (float32, row ``r`` at ``r * stride``), ``plane`` the floats per plane of
    ``tab``; the nine scalars are float32. ``windowed`` (bool): every step's lanes are known
    to lie in its window (:data:`WINDOW_SPAN`), so the variant without the check runs
    (AVX-512 and AVX2; elsewhere the flag changes nothing).
    """
    f = types.float32
    i = types.int64
    sig = types.void(
        nx, ny, tx, ty, tab, i, acc_re, acc_im, i, i, i, i, f, f, f, f, f, f, f, f, f,
        types.boolean,
    )  # fmt: skip

    def codegen(context, builder, signature, args):
        context.active_code_library.add_llvm_module(llvm.parse_assembly(_IR))
        byte_ptr = ir.IntType(8).as_pointer()
        i64 = ir.IntType(64)
        fnty = ir.FunctionType(ir.VoidType(), [byte_ptr] * 7 + [i64] * 4 + [ir.FloatType()] * 9)
        fn = cgutils.get_or_insert_function(builder.module, fnty, _NAME)

        def data(k: int, offset=None):
            arr = context.make_array(signature.args[k])(context, builder, args[k])
            ptr = arr.data if offset is None else builder.gep(arr.data, [offset])
            return builder.bitcast(ptr, byte_ptr)

        ptrs = [data(0), data(1), data(2), data(3), data(4, args[5]), data(6), data(7)]
        call_args = ptrs + list(args[8:21])
        if not ISA:
            builder.call(fn, call_args)
            return context.get_dummy_value()
        fn_windowed = cgutils.get_or_insert_function(builder.module, fnty, _NAME_WINDOWED)
        flag = context.cast(builder, args[21], signature.args[21], types.boolean)
        with builder.if_else(flag) as (then, otherwise):
            with then:
                builder.call(fn_windowed, call_args)
            with otherwise:
                builder.call(fn, call_args)
        return context.get_dummy_value()

    return sig, codegen


@numba.njit(inline="always")
def lanes_in_window(q0, r_anchor, ddx, h, hx, lane_run, reach, hi):
    """Whether every step of one pulse on one tile may skip the window check (bool).

    ``q0`` the anchor's table position, ``r_anchor`` its range (m), ``ddx`` its distance
    from the antenna along the lanes (m, >= 0), ``h`` the largest distance of a tile pixel
    from the anchor (m), ``hx`` its part along the lanes, ``lane_run`` ``(LANES - 1) |dx|
    |idx_scale|``, ``reach`` ``h |idx_scale| + 1``, ``hi`` the table's end (the bounds of
    :func:`tile_pulses`).
    """
    return (
        r_anchor > h
        and lane_run * (ddx + hx) <= WINDOW_SPAN * (r_anchor - h)
        and q0 - reach >= 1.0
        and q0 + reach < hi
    )


@numba.njit(inline="always")
def tile_pulses(
    tab, j0, j1, ant_x, ant_y, ant_z2, ref, xc, yc, dx, dy, c0, cc, r0, rc, nr, ncp,
    idx_scale, idx_offset, hi, quarter_scale, acc_re, acc_im,
):  # pragma: no cover - compiled  # fmt: skip
    """Add pulses ``j0:j1`` to one tile's float32 accumulators (``nr x ncp``, row-major).

    Per pulse, the anchor quantities at the tile's centre pixel ``(cc, rc)`` (at ``xc,
    yc``, m) are float64: its range, the fractional sample index, and the carrier phase of
    the anchor plus the part of each pixel's phase linear in ``N``, ``sq a1 Nx[k]`` and
    ``sq a1 Ny[r]``, each reduced exactly to ``[-2, 2)`` quarter cycles. The pixels'
    offsets ``Nx = u (u + 2 dx_a)`` along columns and ``Ny = v (v + 2 dy_a)`` along rows go
    to :func:`tile_pulse` in float32 with the series coefficients of the range; only the
    series' higher terms (a small fraction of a cycle) enter the phase in float32. Shared
    by exact backprojection and the FFBP leaves.

    A pulse runs the unchecked window variant of :func:`tile_pulse` when two bounds hold:
    every pixel of the tile (padding columns included) is within ``h`` of the anchor, so
    its range is within ``h`` of the anchor's and its table position within ``h |s|``
    (``s`` = ``idx_scale``) of the anchor's, an interval inside ``[1 + 1, hi - 1)`` (a
    margin of one entry for the float32 evaluation); and along a step's ``LANES`` pixels the range
    changes at most ``(LANES - 1) |dx| (|x_a - a_x| + h_x) / (R_a - h)``, which in table
    entries is at most :data:`WINDOW_SPAN`.
    """
    stride = tab.shape[1]
    plane = stride // 8
    f32 = np.float32
    si = f32(idx_scale)
    sq = f32(quarter_scale)
    nxv = np.empty(ncp, np.float32)
    nyv = np.empty(nr, np.float32)
    txv = np.empty(ncp, np.float32)
    tyv = np.empty(nr, np.float32)
    hx = max(cc - c0, c0 + ncp - 1 - cc) * abs(dx)
    hy = max(rc - r0, r0 + nr - 1 - rc) * abs(dy)
    h = math.sqrt(hx * hx + hy * hy)
    lane_run = (LANES - 1) * abs(dx) * abs(idx_scale)
    reach = h * abs(idx_scale) + 1.0
    for j in range(j0, j1):
        ddx = xc - ant_x[j]
        ddy = yc - ant_y[j]
        r_anchor = math.sqrt(ddx * ddx + ddy * ddy + ant_z2[j])
        d0 = r_anchor - ref[j]
        q0 = d0 * idx_scale + idx_offset
        i0 = math.floor(q0)
        windowed = lanes_in_window(q0, r_anchor, abs(ddx), h, hx, lane_run, reach, hi)
        t0 = d0 * quarter_scale
        t0 -= 4.0 * np.rint(0.25 * t0)  # whole cycles, exact
        inv = 1.0 / r_anchor
        inv2 = inv * inv
        lin = 0.5 * inv * quarter_scale  # quarter cycles per m^2 of N, linear term
        bx = 2.0 * ddx
        by = 2.0 * ddy
        for k in range(ncp):
            u = (c0 + k - cc) * dx
            nk = u * (u + bx)
            nxv[k] = nk
            t = t0 + lin * nk
            txv[k] = t - 4.0 * np.rint(0.25 * t)
        for r in range(nr):
            v = (r0 + r - rc) * dy
            nr_ = v * (v + by)
            nyv[r] = nr_
            t = lin * nr_
            tyv[r] = t - 4.0 * np.rint(0.25 * t)
        tile_pulse(
            nxv, nyv, txv, tyv, tab, j * stride, acc_re, acc_im, ncp, nr, ncp, plane,
            f32(q0 - i0), f32(i0), f32(0.5 * inv), f32(-0.125 * inv * inv2),
            f32(0.0625 * inv * inv2 * inv2), f32(-5.0 / 128.0 * inv * inv2 * inv2 * inv2),
            si, sq, hi, windowed,
        )  # fmt: skip
