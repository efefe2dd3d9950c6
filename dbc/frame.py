"""The frames pacc's nodes exchange: :class:`Frame`, a python-can message whose deep copy is
cheap, and raw frames, the in-process lockstep bus's form without any message object.

A raw frame (:data:`Raw`) is ``(timestamp s, key, payload bytes)``: the key is the id with
:data:`EFF_FLAG` on top for a 29-bit id (:func:`raw_key`), the payload immutable. A frame that
is not a plain classic data frame (error, remote, CAN FD, or a DLC other than its length) is
``(timestamp, OTHER, message)``. :func:`raw_of` and :func:`message_of` convert both ways;
:mod:`dbc.lockstep` carries them, :meth:`dbc.endpoint.Inbox.accept_raw` and the bus recorder
read them.

A module of its own so that :mod:`dbc.endpoint` can be compiled (``tools/compile.py``, mypyc)
while :class:`Frame` stays a plain Python subclass of :class:`can.Message` (mypyc refuses
``__slots__`` on a class derived from an interpreted one).
"""

from __future__ import annotations

from typing import Any

import can
from can.typechecking import Channel

_new_message = can.Message.__new__
#: the extended-id bit of a raw frame's key (SocketCAN's CAN_EFF_FLAG)
EFF_FLAG = 0x80000000
#: the id bits of a raw frame's key
ID_MASK = 0x1FFFFFFF
#: the key of a raw entry that is not a plain data frame (its third item is the message)
OTHER = -1
#: one frame for a raw reader: (timestamp s, key, payload bytes) or (timestamp, OTHER, message)
Raw = tuple[float, int, Any]


def raw_key(frame_id: int, extended: bool) -> int:
    """A frame's key for raw readers: ``frame_id``, with :data:`EFF_FLAG` for a 29-bit id."""
    return frame_id | EFF_FLAG if extended else frame_id


def raw_of(msg: can.Message, channel: Channel | None = None) -> Raw:
    """The raw entry of ``msg`` received on ``channel``: ``(timestamp, key, bytes of the
    payload)`` for a classic data frame whose DLC is its length, else ``(timestamp, OTHER, a
    received copy)`` (an error, remote or CAN FD frame, or a DLC python-can let differ)."""
    if msg.is_error_frame or msg.is_remote_frame or msg.is_fd or msg.dlc != len(msg.data):
        return (msg.timestamp, OTHER, rx_copy(msg, channel))
    return (msg.timestamp, raw_key(msg.arbitration_id, msg.is_extended_id), bytes(msg.data))


def message_of(entry: Raw, channel: Channel | None, is_rx: bool = True) -> can.Message:
    """The :class:`can.Message` a raw entry stands for, stamped with ``channel`` and ``is_rx``."""
    t, key, data = entry
    if key == OTHER:
        return rx_copy(data, channel, is_rx)
    m = _new_message(can.Message)
    m.timestamp = t
    m.arbitration_id = key & ID_MASK
    m.is_extended_id = key >= EFF_FLAG
    m.is_remote_frame = False
    m.is_error_frame = False
    m.channel = channel
    m.dlc = len(data)
    m.data = bytearray(data)
    m.is_fd = False
    m.is_rx = is_rx
    m.bitrate_switch = False
    m.error_state_indicator = False
    return m


def rx_copy(msg: can.Message, channel: Channel | None, is_rx: bool = True) -> can.Message:
    """A received copy of ``msg``: a new :class:`can.Message` that shares no mutable state
    with it (a new payload ``bytearray``), stamped with ``channel`` and ``is_rx`` (False on
    the sender's own echo, as python-can's virtual bus does)."""
    m = _new_message(can.Message)
    m.timestamp = msg.timestamp
    m.arbitration_id = msg.arbitration_id
    m.is_extended_id = msg.is_extended_id
    m.is_remote_frame = msg.is_remote_frame
    m.is_error_frame = msg.is_error_frame
    m.channel = channel
    m.dlc = msg.dlc
    m.data = bytearray(msg.data)
    m.is_fd = msg.is_fd
    m.is_rx = is_rx
    m.bitrate_switch = msg.bitrate_switch
    m.error_state_indicator = msg.error_state_indicator
    return m


class Frame(can.Message):
    """A python-can message whose deep copy is cheap.

    python-can's virtual bus deep-copies every sent message once per receiver; the generic
    ``copy.deepcopy`` of the payload bytearray is the largest single cost of a lockstep
    drive. A frame's fields are immutable scalars but for the payload, so copying the
    payload by hand gives the same result (a plain :class:`can.Message` the receiver owns)
    at a fraction of the cost.
    """

    __slots__ = ()

    def __deepcopy__(self, memo: dict[int, Any] | None) -> can.Message:
        return can.Message(
            timestamp=self.timestamp,
            arbitration_id=self.arbitration_id,
            is_extended_id=self.is_extended_id,
            is_remote_frame=self.is_remote_frame,
            is_error_frame=self.is_error_frame,
            channel=self.channel,
            dlc=self.dlc,
            data=bytearray(self.data),
            is_fd=self.is_fd,
            is_rx=self.is_rx,
            bitrate_switch=self.bitrate_switch,
            error_state_indicator=self.error_state_indicator,
        )


__all__ = [
    "EFF_FLAG",
    "ID_MASK",
    "OTHER",
    "Frame",
    "Raw",
    "message_of",
    "raw_key",
    "raw_of",
    "rx_copy",
]
