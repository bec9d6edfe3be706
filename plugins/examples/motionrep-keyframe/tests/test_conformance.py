"""motionrep's conformance suite, run by the plugin on itself: the way a third party tests its plugin."""

from motionrep.testing import check_codec, check_representation

from motionrep_keyframe import KeyframeCodec, LocalQuaternion


def test_local_quaternion_conforms():
    check_representation(LocalQuaternion())


def test_keyframe_codec_conforms():
    check_codec(KeyframeCodec(), representation=LocalQuaternion())
