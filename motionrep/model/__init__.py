"""The model wing: what a motion is and how it is measured, below everything else.

The pose model (:class:`~motionrep.model._pose.Skeleton`, :class:`~motionrep.model._pose.Motion`), rotations,
forward kinematics, the pose plan (feature columns to poses), operations on motions, frame times, synthetic
clips and the error bound.  Nothing here reads or writes files or knows about plugins."""
