"""Recording and replay: raw sensor units and the stack's outputs in MCAP files of protobuf.

- :mod:`recordings.recorder`: ``Recorder`` (listener, context manager, own writer thread).
- :mod:`recordings.player`: ``Player`` (log-time order on the recording's own clock, any rate).
- :mod:`recordings.reader`: ``RecordingReader`` (complete files by index, killed ones by scan).
- :mod:`recordings.info`: ``info(path)``; :mod:`recordings.hashing`: ``OutputHasher``.
- :mod:`recordings.codec`: ``to_proto`` / ``from_proto``; :mod:`recordings.topics`: topic names.

Nothing is imported here: Main's configuration imports :mod:`recordings.config` at start-up.
"""
