"""A structural check of MATLAB v5 files before :func:`scipy.io.loadmat` reads them.

scipy's compiled reader trusts the element headers of a file: a corrupted header (a
complex flag without an imaginary part, a dimension larger than the data) can make it
read past the data and crash the interpreter (a single flipped bit in the array flags
of a GOTCHA file's ``data.x`` can: ``docs/notes/readers.md``). This
module walks the element tree of the file in pure Python and refuses, with a one-line
reason, every element that does not fit inside its parent or whose declared dimensions
do not match its bytes. A file that passes is safe to hand to scipy.

Format (MathWorks, "MAT-File Format", version 5): a 128-byte header ending in the
endian indicator ``IM``/``MI``; then data elements, each an 8-byte tag (type, byte
count; or the 4-byte "small element" form with the count in the upper 16 bits) and its
data padded to 8 bytes. ``miMATRIX`` elements hold array flags, dimensions, a name and,
by class, real/imaginary parts, struct field names and fields, cells, or sparse indices;
``miCOMPRESSED`` elements hold a zlib stream of further elements.

Only the variables asked for (``data`` for GOTCHA files) are walked to the end and
inflated; of every other variable the header alone is read (the first
:data:`_HEADER_BYTES` of its zlib stream), as :func:`scipy.io.loadmat` with
``variable_names`` skips them. The walk adds up the bytes scipy will allocate for the
variables asked for (:attr:`MatSummary.loaded_bytes`) and refuses a zlib stream that
inflates beyond ``max_inflated`` (in total over those variables): five compressed 1 GB
arrays of zeros next to ``data`` cost nothing, and a ``data`` that inflates beyond the
memory limit is refused before it is inflated.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Collection
from dataclasses import dataclass

from ..errors import InputError

__all__ = ["MatInflationError", "MatStructureError", "MatSummary", "check_mat_v5"]

_MI_SIZES = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 9: 8, 12: 8, 13: 8, 16: 1, 17: 2, 18: 4}
_MI_MATRIX, _MI_COMPRESSED = 14, 15
_NUMERIC_CLASSES = set(range(6, 16))
_CHAR, _STRUCT, _CELL, _SPARSE = 4, 2, 1, 5
_MAX_DEPTH = 16
_MAX_INFLATED = 1 << 31
#: Bytes inflated of a variable that is not read, enough for its header (flags, up to
#: thousands of dimensions, a name).
_HEADER_BYTES = 1 << 16
#: numpy bytes per element of each MATLAB class (char: UCS-4); struct and cell elements
#: become Python objects, counted at :data:`_OBJECT_BYTES` each.
_CLASS_BYTES = {4: 4, 6: 8, 7: 4, 8: 1, 9: 1, 10: 2, 11: 2, 12: 4, 13: 4, 14: 8, 15: 8}
_OBJECT_BYTES = 128


class MatStructureError(InputError):
    """The element structure of a MATLAB v5 file is corrupt (a short reason)."""


class MatInflationError(MatStructureError):
    """The variables to read inflate beyond the allowed size."""


@dataclass
class MatSummary:
    """What :func:`scipy.io.loadmat` will allocate for the variables walked."""

    names: list[str]  # every variable of the file, in order
    loaded_bytes: int = 0  # bytes of the arrays of the variables asked for
    largest_elements: int = 0  # elements of their largest numeric array
    inflated_bytes: int = 0  # bytes of their zlib streams, inflated


def check_mat_v5(
    raw: bytes,
    *,
    variables: Collection[str] | None = None,
    max_inflated: int = _MAX_INFLATED,
) -> MatSummary:
    """Raise :class:`MatStructureError` unless ``raw`` is a well-formed MATLAB v5 file.

    Parameters
    ----------
    raw : bytes
        The file.
    variables : collection of str, optional
        The variables to walk to the end (module notes); default all.
    max_inflated : int
        Largest total size (bytes) of the inflated zlib streams of those variables;
        :class:`MatInflationError` beyond it, raised before inflating further.

    Returns
    -------
    MatSummary
        The variable names and the bytes the variables asked for will take once loaded.
    """
    if len(raw) < 128:
        raise MatStructureError(f"shorter than the 128-byte MATLAB header ({len(raw)} bytes)")
    order = {b"IM": "<", b"MI": ">"}.get(raw[126:128])
    if order is None:
        raise MatStructureError("no MATLAB v5 endian indicator in the header")
    walker = _Walker(order, variables, max_inflated)
    walker.elements(raw, 128, len(raw), depth=0, top=True)
    return walker.summary


def _inflate(data: bytes, budget: int) -> bytearray:
    """The zlib stream ``data`` inflated 16 MB at a time; MatInflationError beyond ``budget``."""
    inflater = zlib.decompressobj()
    out = bytearray()
    tail = data
    while tail:
        out += inflater.decompress(tail, 1 << 24)
        if len(out) > budget:
            raise MatInflationError(f"its variables inflate to more than {budget} bytes")
        tail = inflater.unconsumed_tail
    out += inflater.flush()
    if len(out) > budget:
        raise MatInflationError(f"its variables inflate to more than {budget} bytes")
    return out


class _Walker:
    def __init__(self, order: str, variables: Collection[str] | None, max_inflated: int) -> None:
        self.order = order
        self.variables = variables
        self.max_inflated = max_inflated
        self.summary = MatSummary(names=[])

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
                self.compressed(buf[start : start + nbytes], depth, top=top)
            elif mtype == _MI_MATRIX:
                if top and not self.wanted(self.variable_name(buf, start, start + nbytes)):
                    continue
                self.matrix(buf, start, start + nbytes, depth)
            elif mtype not in _MI_SIZES:
                raise MatStructureError(f"unknown element type {mtype} at byte {start - 8}")

    def wanted(self, name: str) -> bool:
        self.summary.names.append(name)
        return self.variables is None or name in self.variables

    def variable_name(self, buf: bytes, pos: int, end: int) -> str:
        """The name of the matrix at ``pos`` (its flags, dimensions and name checked)."""
        if pos == end:
            return ""
        flags, pos = self.values(buf, pos, end, "array flags")
        dims, pos = self.values(buf, pos, end, "dimensions")
        if len(flags) != 2 or len(dims) < 2 or any(d > 2**31 for d in dims):
            raise MatStructureError(f"array flags {flags} or dimensions {dims} are corrupt")
        mtype, nbytes, start, _ = self.tag(buf, pos, end)
        if mtype not in (1, 2, 16) or nbytes > 4096:
            raise MatStructureError(f"array name at byte {pos} has type {mtype}, {nbytes} bytes")
        return bytes(buf[start : start + nbytes]).decode("latin-1")

    def compressed(self, data: bytes, depth: int, *, top: bool = False) -> None:
        budget = self.max_inflated - self.summary.inflated_bytes
        try:
            if top:  # one variable: its header first, all of it only when it is read
                head = zlib.decompressobj().decompress(data, _HEADER_BYTES)
                if len(head) >= 8 and struct.unpack_from(self.order + "I", head)[0] == _MI_MATRIX:
                    if not self.wanted(self.variable_name(head, 8, len(head))):
                        return
            inflated = _inflate(data, budget)
        except zlib.error:
            raise MatStructureError("a compressed element is corrupt") from None
        self.summary.inflated_bytes += len(inflated)
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
        complex_ = bool(flags[0] & 0x800)
        self.summary.loaded_bytes += n * _CLASS_BYTES.get(cls, _OBJECT_BYTES) * (1 + complex_)
        if cls in _NUMERIC_CLASSES:
            self.summary.largest_elements = max(self.summary.largest_elements, n)
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
