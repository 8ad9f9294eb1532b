"""Measurement models by name: prediction h, Jacobians w.r.t. landmark and pose, inverse."""
from .base import MeasurementModel, wrap_angle
from .box import BoxModel
from .point_map import PointMapModel
from .point_robot import PointRobotModel
from .range_bearing import RangeBearingModel

MODELS: dict[str, MeasurementModel] = {
    model.name: model for model in (PointMapModel(), PointRobotModel(), RangeBearingModel(),
                                    BoxModel())
}

__all__ = ['MODELS', 'MeasurementModel', 'wrap_angle']
