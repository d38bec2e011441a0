"""CAN databases (DBC) and the vectorised decoding of their signals.

:func:`load_dbc` reads a DBC with cantools; :func:`signal_layout` turns one of its signals into a
:class:`SignalLayout` (bit position, byte order, sign, scale, offset, range); :func:`decode_signal`
decodes that signal for every frame of a message at once with NumPy. cantools decodes one frame per
call in Python, which is ~100x slower on an hour of bus traffic; the tests check that both give the
same values on random payloads for every signal a profile uses.

Bit numbering follows the DBC convention that cantools uses: the start bit of a little-endian
(Intel, ``@1``) signal is its least significant bit counted from bit 0 of byte 0 upwards; that of a
big-endian (Motorola, ``@0``) signal is its most significant bit, numbered ``8 * byte + bit`` with
bit 7 the MSB of a byte.

Examples
--------
>>> import numpy as np
>>> layout = SignalLayout("S", start=7, length=8, little_endian=False, signed=True,
...                       scale=0.5, offset=0.0, minimum=None, maximum=None, is_float=False)
>>> decode_signal(np.array([[0xFE], [0x02]], dtype=np.uint8), layout).tolist()
[-1.0, 1.0]
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from jaxtyping import Float, UInt8

from ..._errors import BadInputError


@dataclass(frozen=True)
class SignalLayout:
    """Where a signal sits in a payload and how its raw bits become a physical value.

    Parameters
    ----------
    name : str
        Signal name in the DBC.
    start : int
        DBC start bit (LSB for little endian, MSB for big endian; see the module docstring).
    length : int
        Number of bits, 1-64.
    little_endian : bool
        Intel (``@1``) byte order if True, Motorola (``@0``) if False.
    signed : bool
        Two's complement raw value.
    scale, offset : float
        physical = raw * scale + offset [unit of the signal].
    minimum, maximum : float or None
        Physical range the DBC states, or None where it states none.
    is_float : bool
        IEEE 754 raw value (32 or 64 bits) instead of an integer.
    """

    name: str
    start: int
    length: int
    little_endian: bool
    signed: bool
    scale: float
    offset: float
    minimum: float | None
    maximum: float | None
    is_float: bool

    def __post_init__(self) -> None:
        if not 1 <= self.length <= 64:
            raise BadInputError(
                f"signal {self.name}: expected a length of 1-64 bits, got {self.length}"
            )
        if self.is_float and self.length not in (32, 64):
            raise BadInputError(
                f"signal {self.name}: expected a float of 32 or 64 bits, got {self.length}"
            )

    def byte_span(self) -> tuple[int, int]:
        """First and last payload byte (inclusive) that hold bits of the signal."""
        if self.little_endian:
            return self.start // 8, (self.start + self.length - 1) // 8
        msb = 8 * (self.start // 8) + (7 - self.start % 8)  # position counted from the MSB side
        return msb // 8, (msb + self.length - 1) // 8

    def raw_span(self) -> tuple[float, float]:
        """Physical values the bits can hold, lowest and highest [unit of the signal]."""
        if self.is_float:
            return -np.inf, np.inf
        lo, hi = (
            (-(2 ** (self.length - 1)), 2 ** (self.length - 1) - 1)
            if self.signed
            else (
                0,
                2**self.length - 1,
            )
        )
        a, b = lo * self.scale + self.offset, hi * self.scale + self.offset
        return min(a, b), max(a, b)

    def checked_range(self) -> tuple[float, float] | None:
        """The DBC range if it says something about physical values, else None.

        Some databases (opendbc among them) write the raw span, e.g. ``[0|65535]`` for a signal
        whose physical values are negative too; a range that does not lie within what the bits
        can hold is such a raw span and is not checked.
        """
        if self.minimum is None or self.maximum is None or self.minimum >= self.maximum:
            return None
        lo, hi = self.raw_span()
        slack = 0.5 * abs(self.scale)
        if self.minimum < lo - slack or self.maximum > hi + slack:
            return None
        return self.minimum, self.maximum


def load_dbc(path: str | os.PathLike):
    """Read a DBC file with cantools (non-strict: opendbc files have overlapping signals).

    Raises
    ------
    BadInputError
        Missing file or a file cantools cannot parse.
    """
    import cantools

    path = Path(path)
    if not path.is_file():
        raise BadInputError(f"DBC: expected a readable file, got '{path}'")
    try:
        return cantools.database.load_file(str(path), database_format="dbc", strict=False)
    except Exception as err:
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise BadInputError(f"DBC {path.name}: cannot parse ({first})") from None


def signal_layout(signal) -> SignalLayout:
    """A cantools ``Signal`` as a :class:`SignalLayout` (multiplexed signals are refused)."""
    if signal.multiplexer_ids:
        raise BadInputError(
            f"signal {signal.name}: expected a plain signal, got a multiplexed one "
            "(not supported by the vectorised decoder)"
        )
    return SignalLayout(
        name=signal.name,
        start=int(signal.start),
        length=int(signal.length),
        little_endian=signal.byte_order == "little_endian",
        signed=bool(signal.is_signed),
        scale=float(signal.scale),
        offset=float(signal.offset),
        minimum=None if signal.minimum is None else float(signal.minimum),
        maximum=None if signal.maximum is None else float(signal.maximum),
        is_float=bool(signal.is_float),
    )


def raw_bits(data: UInt8[np.ndarray, "n width"], layout: SignalLayout) -> np.ndarray:
    """The signal's raw bits of every frame as unsigned integers (uint64, shape (n,))."""
    first, last = layout.byte_span()
    if last >= data.shape[1]:
        raise BadInputError(
            f"signal {layout.name}: expected payloads of at least {last + 1} bytes, "
            f"got {data.shape[1]}"
        )
    n_bytes = last - first + 1
    mask = np.uint64(2**layout.length - 1)
    if n_bytes > 8:
        # A 57-64 bit signal not aligned to a byte spans 9 bytes: take the bits in two halves.
        return _raw_bits_wide(data, layout)
    window = data[:, first : last + 1].astype(np.uint64)
    if layout.little_endian:
        word = np.zeros(data.shape[0], dtype=np.uint64)
        for k in range(n_bytes):
            word |= window[:, k] << np.uint64(8 * k)
        shift = layout.start % 8
    else:
        word = np.zeros(data.shape[0], dtype=np.uint64)
        for k in range(n_bytes):
            word = (word << np.uint64(8)) | window[:, k]
        msb = 8 * (layout.start // 8) + (7 - layout.start % 8) - 8 * first
        shift = 8 * n_bytes - msb - layout.length
    return (word >> np.uint64(shift)) & mask


def _raw_bits_wide(data: np.ndarray, layout: SignalLayout) -> np.ndarray:
    """Raw bits of a signal spread over 9 bytes, as a high and a low part of <= 32 bits."""
    high_len = layout.length - 32
    plain = {**_fields(layout), "signed": False, "is_float": False}
    if layout.little_endian:
        low = SignalLayout(**{**plain, "length": 32})
        high = SignalLayout(**{**plain, "start": layout.start + 32, "length": high_len})
    else:
        # Motorola: the first bits from the MSB are the high part; the low part starts after them.
        msb = 8 * (layout.start // 8) + (7 - layout.start % 8)
        pos = msb + high_len
        high = SignalLayout(**{**plain, "length": high_len})
        low = SignalLayout(**{**plain, "start": 8 * (pos // 8) + (7 - pos % 8), "length": 32})
    return (raw_bits(data, high) << np.uint64(32)) | raw_bits(data, low)


def _fields(layout: SignalLayout) -> dict:
    return {name: getattr(layout, name) for name in layout.__dataclass_fields__}


def decode_signal(
    data: UInt8[np.ndarray, "n width"], layout: SignalLayout
) -> Float[np.ndarray, "n"]:
    """Physical values of one signal in every frame: bits, sign, scale and offset.

    Parameters
    ----------
    data : ndarray of uint8, shape (n, width)
        Payloads of one message, one frame per row.
    layout : SignalLayout
        The signal.

    Returns
    -------
    ndarray of float64, shape (n,)
        ``raw * scale + offset`` in the DBC's unit, as cantools' ``decode_message`` with
        ``scaling=True`` and no value tables.
    """
    raw = raw_bits(data, layout)
    if layout.is_float:
        value = (
            raw.astype(np.uint32).view(np.float32).astype(np.float64)
            if layout.length == 32
            else raw.view(np.float64)
        )
    elif layout.signed:
        value = raw.view(np.int64)
        if layout.length < 64:
            sign_bit = np.int64(1) << np.int64(layout.length - 1)
            value = np.where(value & sign_bit, value - (sign_bit << np.int64(1)), value)
        value = value.astype(np.float64)
    else:
        value = raw.astype(np.float64)
    return value * layout.scale + layout.offset
