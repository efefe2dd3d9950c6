"""A node's two ends on the bus: the inbox (decode + E2E check, every outcome counted per
role) and the outbox (alive counter + checksum): callers see logical values only."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping
from typing import Any

import can

from dbc.codec import Codec, RoleCodec
from dbc.e2e import E2EReceiver, E2EStatus
from dbc.errors import CrcError, DlcError, EncodeError, RangeError
from dbc.frame import EFF_FLAG, ID_MASK, OTHER, message_of, raw_key
from dbc.message import Decoded, MessageCodec, Value

#: Pseudo-role under which frames of no bound message are counted.
UNKNOWN_ROLE = "?"
#: the E2E outcome of a frame the codec refused, by the error's type (else OUT_OF_RANGE)
_REFUSED: dict[type, E2EStatus] = {CrcError: E2EStatus.WRONG_CRC, DlcError: E2EStatus.WRONG_DLC}
#: the counter outcomes whose frame is dropped
_DROPPED = (E2EStatus.REPEATED, E2EStatus.WRONG_SEQUENCE)


class _Route:
    """What the Inbox needs of one frame id, in one lookup: decoder, E2E receiver, role,
    whether the role merges several messages."""

    __slots__ = ("mc", "decode", "receiver", "role", "merged")

    def __init__(self, mc: MessageCodec, receiver: E2EReceiver, merged: bool) -> None:
        self.mc = mc
        self.decode = mc.decode
        self.receiver = receiver
        self.role = mc.role
        self.merged = merged


class Inbox:
    """Receive side of a node: the latest checked values of each consumed role (``roles``;
    other bound roles ignored, unknown ids counted as UNKNOWN_ID); a role times out after
    ``timeout_multiple`` of its periods."""

    def __init__(self, codec: Codec, roles: Iterable[str], timeout_multiple: float = 10.0) -> None:
        self.codec = codec
        self.roles = tuple(roles)
        #: E2E state per message, keyed by MessageCodec.key (the role for its first message)
        self.receivers: dict[str, E2EReceiver] = {}
        #: roles over several messages or with defaults: merged before they are reported
        self._merge: dict[str, RoleCodec] = {}
        self._partial: dict[str, dict[str, Value]] = {}
        self._seen: dict[str, set[str]] = {}
        #: frame key (:func:`dbc.frame.raw_key`) -> its route
        self._routes: dict[int, _Route] = {}
        #: the E2E receivers of each role's messages (freshness)
        self._role_receivers: dict[str, tuple[E2EReceiver, ...]] = {}
        for role in self.roles:
            rc = codec.roles[role]
            merged = len(rc.parts) > 1 or bool(rc.defaults)
            if merged:
                self._merge[role], self._partial[role], self._seen[role] = rc, {}, set()
            for mc in rc.parts:  # the codec refuses a message without a period
                rx = E2EReceiver(mc.cycle_s, timeout_multiple, mc.counter_modulo or 16)
                self.receivers[mc.key] = rx
                self._routes[raw_key(mc.frame_id, mc.is_extended)] = _Route(mc, rx, merged)
            self._role_receivers[role] = tuple(self.receivers[mc.key] for mc in rc.parts)
        #: the receiver of each one-message role: freshness in one lookup
        self._sole: dict[str, E2EReceiver] = {
            role: rx[0] for role, rx in self._role_receivers.items() if len(rx) == 1
        }
        self._latest: dict[str, dict[str, Value]] = {}
        #: outcomes of frames that belong to no consumed role (counted under UNKNOWN_ROLE)
        self._unknown: Counter[E2EStatus] = Counter()
        self.frames_in = 0

    @property
    def counts(self) -> Counter[tuple[str, E2EStatus]]:
        """Every outcome so far by (role, status): the receivers' counts, derived on demand."""
        out: Counter[tuple[str, E2EStatus]] = Counter()
        for route in self._routes.values():
            for status, n in route.receiver.counts.items():
                out[(route.role, status)] += n
        for status, n in self._unknown.items():
            out[(UNKNOWN_ROLE, status)] += n
        return out

    def accept(self, key: int, data: Any, now_s: float) -> Decoded | None:
        """Check one frame (``key``, ``data`` as :mod:`dbc.frame` gives them) received at
        ``now_s`` (s): the decoded frame if usable, else None. Never raises: bad frames are
        dropped and counted (error and remote frames as WRONG_DLC of the unknown role)."""
        self.frames_in += 1
        route = self._routes.get(key)
        if route is None:
            if key == OTHER:  # not a plain data frame: an FD frame or an odd DLC is decoded
                if data.is_error_frame or data.is_remote_frame:
                    self._unknown[E2EStatus.WRONG_DLC] += 1
                    return None
                key, data = raw_key(data.arbitration_id, data.is_extended_id), data.data
                route = self._routes.get(key)
            if route is None:
                mc = self.codec.by_id.get(key & ID_MASK)
                if mc is None or mc.is_extended != (key >= EFF_FLAG):
                    self._unknown[E2EStatus.UNKNOWN_ID] += 1
                return None
        return self._take(route, data, now_s)

    def _take(self, route: _Route, data: bytes | bytearray, now_s: float) -> Decoded | None:
        """Decode and check one frame of a consumed message (already counted in frames_in)."""
        receiver = route.receiver
        try:
            decoded = route.decode(data)
        except (CrcError, DlcError, RangeError) as exc:
            receiver.record(_REFUSED.get(type(exc), E2EStatus.OUT_OF_RANGE))
            return None
        counter = decoded[2]
        last = receiver.last_counter
        if counter is not None and last is not None and (counter - last) % receiver.modulo == 1:
            # the next counter: OK whatever the timeout (E2EReceiver.check_counter's outcome,
            # without the call)
            receiver.last_counter = counter
            receiver.last_ok_s = now_s
            receiver.ok += 1
        elif counter is None:  # a message without an alive counter
            receiver.last_ok_s = now_s
            receiver.ok += 1
        elif receiver.check_counter(counter, now_s) in _DROPPED:  # counted there
            return None
        if route.merged:
            self._merge_part(route.mc, decoded[1])
        else:
            self._latest[route.role] = decoded[1]
        return decoded

    def _merge_part(self, mc: MessageCodec, values: dict[str, Value]) -> None:
        """Fold one message's values into its role, reported (with its defaults) once every
        message of it has arrived."""
        role = mc.role
        self._partial[role].update(values)
        self._seen[role].add(mc.key)
        if len(self._seen[role]) == len(self._merge[role].parts):
            self._latest[role] = {**self._merge[role].defaults, **self._partial[role]}

    def latest(self, role: str) -> dict[str, Value] | None:
        """The last usable values of ``role`` (even if stale), or None if none arrived."""
        return self._latest.get(role)

    def fresh(self, role: str, now_s: float) -> bool:
        """True when every message of ``role`` was usable within its timeout of ``now_s``."""
        sole = self._sole.get(role)
        if sole is not None:
            last = sole.last_ok_s
            return last is not None and now_s - last <= sole.timeout_s
        return not any(r.timed_out(now_s) for r in self._role_receivers[role])

    def errors(self) -> dict[str, int]:
        """Counts of every non-OK outcome by kind, summed over roles."""
        out: Counter[str] = Counter()
        for (_, status), n in self.counts.items():
            if status is not E2EStatus.OK:
                out[status.value] += n
        return dict(out)


class Outbox:
    """Send side of a node: one alive counter per message (``counters`` by
    :attr:`MessageCodec.key`), the checksum filled by the codec."""

    def __init__(self, codec: Codec) -> None:
        self.codec = codec
        self.counters: dict[str, int] = {mc.key: 0 for mc in codec.by_id.values()}
        self.frames_out = 0

    def encode_part(self, mc: MessageCodec, values: Mapping[str, Any]) -> bytes:
        """Payload of message ``mc`` with the next alive counter (advanced only when built);
        EncodeError on bad values."""
        counter = self.counters[mc.key]
        data = mc.encode(values, counter)
        if mc.counter_modulo:
            self.counters[mc.key] = (counter + 1) % mc.counter_modulo
        self.frames_out += 1
        return data

    def _first(self, role: str) -> MessageCodec:
        try:
            return self.codec.by_role[role]
        except KeyError:
            raise EncodeError(f"no role {role!r} in the binding") from None

    def encode(self, role: str, values: Mapping[str, Any]) -> bytes:
        """Payload of ``role``'s first message (:meth:`encode_part`)."""
        return self.encode_part(self._first(role), values)

    def pack(self, role: str, values: Mapping[str, Any], timestamp: float = 0.0) -> can.Message:
        """:meth:`encode` as a python-can message, for a tool on a python-can bus."""
        mc = self._first(role)
        data = self.encode_part(mc, values)
        return message_of((timestamp, raw_key(mc.frame_id, mc.is_extended), data), None)
