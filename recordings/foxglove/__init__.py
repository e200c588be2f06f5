"""Foxglove's well-known protobuf schemas (``foxglove.SceneUpdate``, ``foxglove.LocationFix``)."""
