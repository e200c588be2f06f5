"""The project's exceptions: one root, a few kinds, re-raised with ``from``."""

from __future__ import annotations


class FsdError(Exception):
    """Root of every error this project raises on purpose."""


class ConfigError(FsdError):
    """A configuration file is missing, unreadable, or has an unknown or mistyped key.

    The message is ONE line naming the file, the key and what was expected.
    """


class SensorError(FsdError):
    """A sensor transport failed (port gone, bus off, socket error)."""


class DecodeError(FsdError):
    """Bytes that do not decode as the protocol they claim to be."""


class RecordingError(FsdError):
    """A recording cannot be written or read."""


class TrackError(FsdError):
    """A track file cannot be loaded or a track is not valid."""
