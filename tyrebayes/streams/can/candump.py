"""A vectorised reader of candump logs (``candump -L``, python-can's ``.log`` writer).

Each line is ``(SECONDS.FRACTION) CHANNEL ID#DATA``, with ``ID`` of 3 (standard) or 8 (extended)
hex digits, ``DATA`` an even number of hex digits, ``ID##F DATA`` for CAN FD (``F`` the flags
digit), ``ID#R`` for a remote frame and ``2000xxxx#...`` (the CAN_ERR_FLAG bit) for an error
frame; python-can appends `` R`` or `` T`` (received, transmitted). The file is read in blocks of
whole lines; in each block the positions of the separators are found with NumPy for all lines at
once, every line's structure and identifier are checked, and only the lines of the wanted
identifiers have their timestamp, channel and payload parsed (a profile needs ~10 % of a bus).
This reads an hour of a full bus (9 million frames) in seconds where a per-line Python reader
takes minutes; see ``benchmarks/can_speed.py``.

Examples
--------
>>> import tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "bus.log"
>>> _ = path.write_text("(1.500000) can0 0AA#0102\\n(1.510000) can0 025#R\\n")
>>> frames, counts = read_candump(path, ids={0xAA})
>>> frames.time_s.tolist(), frames.data.tolist(), counts.remote_frames
([1.5], [[1, 2]], 1)
"""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path

import numpy as np

from ..._errors import BadInputError
from .frame_table import CanFrames, FrameCounts, empty_frames

_CAN_ERR_FLAG = 0x20000000
_ID_MASK = 0x1FFFFFFF
# "(" + up to 12 integer digits + "." + up to 9 fraction digits + ")".
_TIME_WINDOW = 24
# 32 MiB blocks keep the per-line index arrays of one block near 100 MB.
_BLOCK_BYTES = 1 << 25

_HEX = np.full(256, 255, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789ABCDEF"):
    _HEX[_c] = _i
for _i, _c in enumerate(b"abcdef"):
    _HEX[_c] = 10 + _i
_DEC = np.full(256, 255, dtype=np.uint8)
_DEC[np.frombuffer(b"0123456789", dtype=np.uint8)] = np.arange(10, dtype=np.uint8)


def _first_at_or_after(positions: np.ndarray, at: np.ndarray, sentinel: int) -> np.ndarray:
    """For each ``at``, the first of the sorted ``positions`` >= it (``sentinel`` if none)."""
    k = np.searchsorted(positions, at)
    padded = np.append(positions, sentinel)
    return padded[k]


def _in_each_line(
    positions: np.ndarray, starts: np.ndarray, ends: np.ndarray, sentinel: int
) -> np.ndarray:
    """The first of ``positions`` in each line; without a search when each line holds one."""
    if positions.size == starts.size and starts.size:
        # The common case (one ')' and one '#' a line): the i-th position is in the i-th line.
        if np.all(positions >= starts) and np.all(positions < ends):
            return positions
    return _first_at_or_after(positions, starts, sentinel)


def _digits(
    buf: np.ndarray, pos: np.ndarray, width: int, table: np.ndarray, base: int
) -> tuple[np.ndarray, np.ndarray]:
    """Fixed-width numbers at ``pos`` in ``buf``: values (int64) and a mask of bad digits."""
    value = np.zeros(pos.size, dtype=np.int64)
    bad = np.zeros(pos.size, dtype=bool)
    for k in range(width):
        d = table[buf[pos + k]]
        bad |= d == 255
        value *= base
        value += d
    return value, bad


class _Block:
    """Parse one block of whole lines (``buf`` ends with a newline)."""

    def __init__(self, buf: np.ndarray, first_line: int, name: str):
        self.buf, self.first_line, self.name = buf, first_line, name

    def fail(self, row: int, starts: np.ndarray, ends: np.ndarray, what: str) -> None:
        text = bytes(self.buf[starts[row] : min(ends[row], starts[row] + 60)]).decode(
            "ascii", "replace"
        )
        raise BadInputError(
            f"CAN log {self.name}: line {self.first_line + int(self.lines[row]) + 1}: expected "
            f"{what}, got {text!r}"
        )

    def parse(self, ids: np.ndarray | None, bus: bytes | None):
        buf = self.buf
        nl = np.flatnonzero(buf == 10)
        starts = np.concatenate(([0], nl[:-1] + 1))
        ends = nl - (buf[np.maximum(nl - 1, 0)] == 13)  # content end, without a \r
        self.lines = np.flatnonzero(ends > starts)  # empty lines are skipped
        self.n_lines = nl.size
        if self.lines.size < nl.size:
            starts, ends = starts[self.lines], ends[self.lines]
        if starts.size == 0:
            return None
        size = buf.size
        hash_at = _in_each_line(np.flatnonzero(buf == 35), starts, ends, size)  # '#'
        # The identifier has 3 or 8 hex digits between a space and the '#'.
        id_len = np.where(
            buf[np.maximum(hash_at - 4, 0)] == 32,
            3,
            np.where(buf[np.maximum(hash_at - 9, 0)] == 32, 8, 0),
        )
        id_space = hash_at - id_len - 1
        # Every line: "(" first, "ID#" after a space; the timestamp and channel are checked on
        # the kept lines only (finding every ')' would cost a fifth of the reading time).
        ok = (buf[starts] == 40) & (hash_at < ends) & (id_len > 0) & (id_space > starts + 3)
        if not ok.all():
            self.fail(int(np.flatnonzero(~ok)[0]), starts, ends, "'(SECONDS) CHANNEL ID#DATA'")
        can_id = np.zeros(starts.size, dtype=np.int64)
        for width in (3, 8):
            sel = np.flatnonzero(id_len == width)
            if sel.size == starts.size:  # one identifier width in the block: no gathers
                value, bad = _digits(buf, id_space + 1, width, _HEX, 16)
                if bad.any():
                    self.fail(int(np.flatnonzero(bad)[0]), starts, ends, "a hex CAN identifier")
                can_id = value
            elif sel.size:
                value, bad = _digits(buf, id_space[sel] + 1, width, _HEX, 16)
                if bad.any():
                    self.fail(int(sel[bad][0]), starts, ends, "a hex CAN identifier")
                can_id[sel] = value
        after = buf[np.minimum(hash_at + 1, size - 1)]
        after = np.where(hash_at + 1 < ends, after, 0)
        error = (id_len == 8) & ((can_id & _CAN_ERR_FLAG) != 0)
        remote = ~error & ((after == 82) | (after == 114))  # 'R' / 'r'
        data = ~error & ~remote
        self.n_data = int(data.sum())
        self.n_error = int(error.sum())
        self.n_remote = int(remote.sum())
        can_id &= _ID_MASK
        keep = data if ids is None else data & np.isin(can_id, ids)
        rows = np.flatnonzero(keep)
        return self._kept(rows, starts, ends, hash_at, id_space, can_id, bus)

    def _kept(self, rows, starts, ends, hash_at, id_space, can_id, bus):
        buf = self.buf
        s, e, h, sp = starts[rows], ends[rows], hash_at[rows], id_space[rows]
        # The ')' closing the timestamp: where the first kept line has it (one timestamp width
        # throughout a log), else searched in a short window at the start of each line.
        c = s + _TIME_WINDOW
        if s.size:
            first = int(np.argmax(buf[s[0] : s[0] + _TIME_WINDOW] == 41))
            c = s + first
        if not np.all(buf[np.minimum(c, buf.size - 1)] == 41):
            window = buf[np.minimum(s[:, None] + np.arange(_TIME_WINDOW), buf.size - 1)]
            found = window == 41
            c = np.where(found.any(axis=1), s + np.argmax(found, axis=1), s + _TIME_WINDOW)
        ok = (c + 1 < sp) & (buf[np.minimum(c + 1, buf.size - 1)] == 32)
        if not ok.all():
            self.fail(int(rows[~ok][0]), starts, ends, "'(SECONDS) CHANNEL ID#DATA'")
        # Channel names as fixed-width byte strings, one group per name length.
        chan_len = sp - c - 2
        names: list[bytes] = []
        code = np.zeros(rows.size, dtype=np.int64)
        on_bus = np.ones(rows.size, dtype=bool) if bus is None else np.zeros(rows.size, bool)
        for width in np.unique(chan_len).tolist():
            sel = np.flatnonzero(chan_len == width)
            raw = buf[c[sel, None] + 2 + np.arange(width)]
            group = np.ascontiguousarray(raw).view(f"S{width}").ravel()
            if np.all(group == group[0]):  # the common case: one bus
                uniq, inverse = group[:1], np.zeros(sel.size, dtype=np.int64)
            else:
                uniq, inverse = np.unique(group, return_inverse=True)
            code[sel] = len(names) + inverse
            names.extend(bytes(b) for b in uniq.tolist())
            if bus is not None:
                on_bus[sel] = group == bus
        self.buses = names
        self.n_other = int((~on_bus).sum())
        if bus is not None:
            rows, s, e, c, h = rows[on_bus], s[on_bus], e[on_bus], c[on_bus], h[on_bus]
            code = code[on_bus]
        # Timestamp: "(" integer "." fraction ")".
        dot = c - 7  # candump writes microseconds: "(SECONDS.UUUUUU)"
        if not np.all((dot > s + 1) & (buf[np.maximum(dot, 0)] == 46)):
            dot = _first_at_or_after(np.flatnonzero(buf == 46), s, buf.size)
        int_len, frac_len = dot - s - 1, c - dot - 1
        ok = (dot < c) & (int_len >= 1) & (int_len <= 12) & (frac_len >= 1) & (frac_len <= 9)
        if not ok.all():
            self.fail(int(rows[~ok][0]), starts, ends, "a timestamp '(SECONDS.FRACTION)'")
        time_s = np.empty(rows.size)
        key = int_len * 16 + frac_len
        for k in np.unique(key).tolist():
            il, fl = divmod(k, 16)
            sel = np.flatnonzero(key == k)
            whole, bad_w = _digits(buf, s[sel] + 1, il, _DEC, 10)
            frac, bad_f = _digits(buf, dot[sel] + 1, fl, _DEC, 10)
            if (bad_w | bad_f).any():
                self.fail(int(rows[sel][bad_w | bad_f][0]), starts, ends, "a timestamp")
            time_s[sel] = whole + frac / 10.0**fl
        # Payload: after "#" (or "##F" for CAN FD), up to an optional " R"/" T".
        fd = buf[h + 1] == 35
        d0 = h + 1 + 2 * fd
        tail = (e - d0 >= 2) & (buf[np.maximum(e - 2, 0)] == 32)
        tail &= np.isin(buf[np.maximum(e - 1, 0)], np.frombuffer(b"RTrt", dtype=np.uint8))
        d1 = e - 2 * tail
        n_hex = d1 - d0
        ok = (n_hex >= 0) & (n_hex % 2 == 0) & (n_hex <= 128)
        if not ok.all():
            self.fail(int(rows[~ok][0]), starts, ends, "an even number of hex digits")
        n_bytes = n_hex // 2
        width = int(n_bytes.max()) if n_bytes.size else 8
        data = np.zeros((rows.size, max(width, 1)), dtype=np.uint8)
        for nb in np.unique(n_bytes):
            if nb == 0:
                continue
            sel = np.flatnonzero(n_bytes == nb)
            d = _HEX[buf[d0[sel, None] + np.arange(2 * nb)]]
            bad = np.any(d == 255, axis=1)
            if bad.any():
                self.fail(int(rows[sel][bad][0]), starts, ends, "hex payload digits")
            data[sel, :nb] = (d[:, 0::2] << 4) | d[:, 1::2]
        return time_s, can_id[rows], data, n_bytes, code


def read_candump(
    path: str | Path, *, ids: Collection[int] | None = None, bus: str | None = None
) -> tuple[CanFrames, FrameCounts]:
    """Read a candump log with NumPy.

    Parameters
    ----------
    path : path-like
        A candump ``-L`` log (``.log``).
    ids : collection of int, optional
        Identifiers to keep (default: all).
    bus : str, optional
        Channel name to keep (e.g. ``can0``).

    Returns
    -------
    (CanFrames, FrameCounts)
        Frames of the wanted identifiers in file order, and the counts.

    Raises
    ------
    BadInputError
        A line that is not a candump frame (the line number and its text are named), or a last
        line without its newline (a truncated file).
    """
    path = Path(path)
    wanted = None if ids is None else np.asarray(sorted(ids), dtype=np.int64)
    bus_bytes = None if bus is None else bus.encode()
    parts: list[tuple] = []
    n_data = n_error = n_remote = n_other = 0
    buses: set[bytes] = set()
    line = 0
    block = bytearray(_BLOCK_BYTES)
    held = 0  # bytes of an unfinished line carried to the front of the block
    with open(path, "rb") as fh:
        while True:
            if held == len(block):  # a line longer than the block: make room
                block.extend(bytes(len(block)))
            with memoryview(block) as view:
                got = fh.readinto(view[held:])
            if not got:
                break
            total = held + got
            cut = block.rfind(b"\n", 0, total)
            if cut < 0:
                held = total
                continue
            parser = _Block(np.frombuffer(block, dtype=np.uint8, count=cut + 1), line, path.name)
            kept = parser.parse(wanted, bus_bytes)
            line += parser.n_lines
            if kept is not None:
                n_data += parser.n_data
                n_error += parser.n_error
                n_remote += parser.n_remote
                n_other += parser.n_other
                buses |= set(parser.buses)
                if kept[0].size:
                    parts.append((*kept, parser.buses))
            del parser  # releases its view of the block before the block is reused
            held = total - (cut + 1)
            block[:held] = block[cut + 1 : total]
    carry = bytes(block[:held])
    if carry.strip():
        text = carry[:60].decode("ascii", "replace")
        raise BadInputError(
            f"CAN log {path.name}: line {line + 1}: expected a line ending in a newline, got "
            f"{text!r} at the end of the file (truncated file?)"
        )
    order = sorted(buses)
    names = tuple(b.decode("ascii", "replace") for b in order)
    if not parts:
        return empty_frames(), FrameCounts(n_data, n_error, n_remote, 0, n_other, names)
    # Each block numbered its own buses: renumber them in the log's sorted list.
    index = {b: i for i, b in enumerate(order)}
    codes = [np.array([index[b] for b in p[5]], dtype=np.int64)[p[4]] for p in parts]
    width = max(p[2].shape[1] for p in parts)
    data = np.zeros((sum(p[2].shape[0] for p in parts), width), dtype=np.uint8)
    row = 0
    for p in parts:
        data[row : row + p[2].shape[0], : p[2].shape[1]] = p[2]
        row += p[2].shape[0]
    frames = CanFrames(
        np.concatenate([p[0] for p in parts]),
        np.concatenate([p[1] for p in parts]),
        data,
        np.concatenate([p[3] for p in parts]).astype(np.int64),
        np.concatenate(codes),
        names,
    )
    return frames, FrameCounts(n_data, n_error, n_remote, frames.time_s.size, n_other, names)
