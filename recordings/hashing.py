"""``OutputHasher``: one SHA-256 over every output of a run, in order.

Each update hashes the topic and the deterministic protobuf serialisation of the message
(:func:`recordings.codec.to_proto`, ``SerializeToString(deterministic=True)``), each framed by
its length, so the same sequence of outputs gives the same digest in any process, at any
replay rate, and a different sequence (or the same messages on other topics) does not.
"""

from __future__ import annotations

import hashlib
import struct

from google.protobuf.message import Message as ProtoMessage

from recordings.codec import to_proto

_LENGTH = struct.Struct("<Q")


def canonical_bytes(message: object) -> bytes:
    """The canonical byte form of a message (deterministic protobuf serialisation)."""
    proto = message if isinstance(message, ProtoMessage) else to_proto(message)
    return proto.SerializeToString(deterministic=True)


class OutputHasher:
    """SHA-256 over ``(topic, message)`` updates: map states, plans and commands in order."""

    def __init__(self) -> None:
        self._sha = hashlib.sha256()
        self.count = 0
        """Messages hashed so far."""

    def update(self, topic: str, message: object) -> None:
        """Add one output (a :mod:`common.messages` object or an ``fsd`` protobuf message)."""
        name = topic.encode("utf-8")
        data = canonical_bytes(message)
        self._sha.update(_LENGTH.pack(len(name)))
        self._sha.update(name)
        self._sha.update(_LENGTH.pack(len(data)))
        self._sha.update(data)
        self.count += 1

    def hexdigest(self) -> str:
        """The digest of everything so far (hex); further updates may follow."""
        return self._sha.hexdigest()
