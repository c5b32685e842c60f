"""perception subpackage: the paper's sonar feature step (corners, edges → obstacles)."""

from uhrisim.perception.features import FeatureParams, SonarFeatures, extract_features

__all__ = ["FeatureParams", "SonarFeatures", "extract_features"]
