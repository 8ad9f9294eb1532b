"""Multi-hypothesis association with retrospective re-evaluation (Shelly & Indelman, RA-L 2022;
seed 001, ../shared/specs/multi_hypothesis.md): a Gaussian-mixture pose belief over a tree of
data-association hypotheses, exact (tree-sum) and sampled (particle filter) re-evaluation of a
past step.  No ROS."""
from .motion import compose, compose_jacobians
from .reevaluation import ParticleReevaluation, reevaluate_naive
from .tree import HypothesisTree

__all__ = ['HypothesisTree', 'ParticleReevaluation', 'compose', 'compose_jacobians',
           'reevaluate_naive']
