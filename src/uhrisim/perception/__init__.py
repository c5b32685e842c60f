"""perception subpackage: the paper's sonar feature step (corners, edges → obstacles), and
finding and tracking the diver in sonar pings (docs/perception.md): detection, blobs, a
multi-target tracker, a diver/clutter classifier, composed by :class:`SonarPerception`."""

from uhrisim.perception.blobs import Blob, BlobImage, BlobParams, extract_blobs
from uhrisim.perception.classify import DiverClassifier
from uhrisim.perception.detect import BackgroundModel, DetectorParams, cfar_mask
from uhrisim.perception.features import FeatureParams, SonarFeatures, extract_features
from uhrisim.perception.pipeline import (
    PerceptionFrame,
    PerceptionParams,
    SonarPerception,
    TrackReport,
)
from uhrisim.perception.tracker import FanView, MultiTargetTracker, TrackerParams

__all__ = [
    "BackgroundModel",
    "Blob",
    "BlobImage",
    "BlobParams",
    "DetectorParams",
    "DiverClassifier",
    "FanView",
    "FeatureParams",
    "MultiTargetTracker",
    "PerceptionFrame",
    "PerceptionParams",
    "SonarFeatures",
    "SonarPerception",
    "TrackReport",
    "TrackerParams",
    "cfar_mask",
    "extract_blobs",
    "extract_features",
]
