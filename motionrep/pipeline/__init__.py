"""The pipeline wing: one clip from source to compressed file and back, and how its error is measured.

Clip sources, the compression pipeline, the one decode path, the runtime decoder (``motionrep.open``), the
shared FK L-infinity error and the pairing of clips from other tools, and the size vocabulary."""
