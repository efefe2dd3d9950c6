"""The python-can message pacc's nodes send: :class:`Frame`, whose deep copy is cheap.

A module of its own so that :mod:`dbc.endpoint` can be compiled (``tools/compile.py``, mypyc)
while this class stays a plain Python subclass of :class:`can.Message` (mypyc refuses
``__slots__`` on a class derived from an interpreted one).
"""

from __future__ import annotations

from typing import Any

import can


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


__all__ = ["Frame"]
