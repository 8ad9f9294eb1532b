"""One associator per module; REGISTRY maps each `algorithm` name to its Associator."""
from . import euclidean_nn, gnn, iou, jcbb, jcbb_points, mahalanobis_nn, maximum_likelihood
from .base import Associator

REGISTRY: dict[str, Associator] = {
    module.ASSOCIATOR.name: module.ASSOCIATOR
    for module in (euclidean_nn, mahalanobis_nn, maximum_likelihood, gnn, jcbb, jcbb_points,
                   iou)
}

__all__ = ['REGISTRY', 'Associator']
