"""motionrep in ``torch`` (``pip install "motionrep[torch]"``): datasets over motion databases.

``import motionrep`` never imports this package; importing it imports torch.
"""

from ._dataset import MotionDataset, WindowSampler
from ._split import split_clips
from ._stats import FeatureStats

__all__ = ["MotionDataset", "WindowSampler", "FeatureStats", "split_clips"]
