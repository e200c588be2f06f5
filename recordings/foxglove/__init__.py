"""Foxglove's well-known protobuf schemas (:mod:`recordings.foxglove.schemas`, from the
``foxglove-schemas-protobuf`` package) and the Foxglove layout shipped with the stack."""
