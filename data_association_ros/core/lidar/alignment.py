"""Rigid correction of a track's predicted pose from its matched scan points (seed 003's
"transformation estimation"), three ways (`transform`):

* kabsch: least squares over the point pairs (the seed; core.transforms.estimate_rigid_transform);
* ransac: RANSAC over minimal samples of pairs, then Kabsch on the inliers (the seed's cheaper
  alternative; core.transforms.ransac_rigid_transform);
* point_to_line (added here): each pair (s, b) constrains only the distance of s from the line of
  b's face, r = n . (s - X(b)); each cluster end that is an object edge constrains the nearest
  visible model corner in 2-D.  Why: scan points sit at fixed beam angles, so a point-to-point
  pair on a face says nothing about sliding along that face, yet Kabsch counts it as "no
  sliding" and shrinks the correction by the share of such pairs (the aperture problem); the
  face's ends (the cluster's edge points) are what carries that component.

The correction X(p) = c + R(yaw)(p - c) + t moves the predicted boundary onto the scan, c being the
predicted centre; it is reported as `Correction` with the covariance of (t_x, t_y, yaw).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInputError
from ..transforms import estimate_rigid_transform, ransac_rigid_transform
from .shape import rotation, seen_faces

TRANSFORMS = ('point_to_line', 'kabsch', 'ransac')
J = np.array([[0.0, -1.0], [1.0, 0.0]])
"""dR(a)/da = J R(a)."""


@dataclass(frozen=True)
class Correction:
    """X(p) = centre + R(yaw)(p - centre) + translation; covariance (3, 3) of (t_x, t_y, yaw)
    [m^2, m rad, rad^2]."""

    centre: np.ndarray
    translation: np.ndarray
    yaw: float
    covariance: np.ndarray

    def apply(self, points: np.ndarray) -> np.ndarray:
        """(n, 2) -> (n, 2) corrected points."""
        return (np.asarray(points, float) - self.centre) @ rotation(self.yaw).T + self.centre \
            + self.translation


@dataclass(frozen=True)
class EdgePoint:
    """A cluster end that is an object edge: the end point (2,), the unit direction (2,) along the
    face towards the end, and the spacing [m] to the previous point of the cluster (the true
    corner lies 0 to one spacing beyond the end point, uniformly)."""

    point: np.ndarray
    outward: np.ndarray
    spacing: float


def from_rigid(transform, centre: np.ndarray) -> Correction:
    """A RigidTransform2D q = R p + t as a Correction about `centre`: translation = R c + t - c;
    covariance mapped by d(translation, yaw)/d(x, y, yaw) = [[I, J R c], [0, 1]]."""
    r = transform.rotation()
    g = np.eye(3)
    g[:2, 2] = J @ r @ centre
    return Correction(np.asarray(centre, float), transform.apply(centre[None])[0] - centre,
                      float(transform.yaw), g @ transform.covariance @ g.T)


def rigid_correction(scan: np.ndarray, boundary: np.ndarray, pairs: np.ndarray,
                     centre: np.ndarray, ransac: bool = False,
                     inlier_threshold: float = 0.1) -> Correction:
    """kabsch / ransac over the pairs (n, 2) of scan (K, 2) and boundary (N, 2) points.
    Raises InvalidInputError when the pairs cannot fix a transform."""
    source, target = boundary[pairs[:, 1]], scan[pairs[:, 0]]
    transform = ransac_rigid_transform(source, target, inlier_threshold) if ransac \
        else estimate_rigid_transform(source, target)
    return from_rigid(transform, np.asarray(centre, float))


def gated_edges(edges: list[EdgePoint], corners: np.ndarray, centre: np.ndarray,
                pose_covariance: np.ndarray, sigma: float, gate: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """point_to_line_correction's edge residuals: (expected (E, 2), model corner (E, 2),
    information (E, 2, 2)) of the edges whose expected corner e + h/2 d lies within `gate`
    (squared Mahalanobis distance) of the nearest of `corners` (k, 2), with covariance
    sigma^2 I + h^2 / 12 d d^T + A pose_covariance A^T, A = [I, J (k - centre)]; the
    information is the inverse of the first two terms."""
    if not edges or not len(corners):
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2, 2))
    outward = np.array([edge.outward for edge in edges], float)
    spacing = np.array([edge.spacing for edge in edges], float)
    expected = np.array([edge.point for edge in edges], float) + outward * spacing[:, None] / 2
    covariance = sigma ** 2 * np.eye(2) + (spacing ** 2 / 12)[:, None, None] * (
        outward[:, :, None] * outward[:, None, :])
    offsets = corners[None] - expected[:, None]
    corner = corners[np.argmin(np.hypot(offsets[..., 0], offsets[..., 1]), axis=1)]
    a = np.zeros((len(edges), 2, 3))
    a[:, :, :2] = np.eye(2)
    a[:, :, 2] = (corner - centre) @ J.T
    innovation = expected - corner
    total = covariance + a @ pose_covariance @ a.transpose(0, 2, 1)
    inside = np.einsum('ed,ed->e', innovation,
                       np.linalg.solve(total, innovation[:, :, None])[:, :, 0]) <= gate
    return expected[inside], corner[inside], np.linalg.inv(covariance[inside])


def point_to_line_correction(scan: np.ndarray, boundary: np.ndarray, pairs: np.ndarray,
                             corner_points: np.ndarray, edges: list[EdgePoint],
                             centre: np.ndarray, pose_covariance: np.ndarray, sigma: float,
                             gate: float = 13.8, prior_sigmas=(1.0, 1.0, 0.5),
                             iterations: int = 3,
                             sensor: np.ndarray = np.zeros(2), reach: float = 1e-6) -> Correction:
    """Gauss-Newton over (t_x, t_y, yaw) from 0 (see the module docstring).

    scan (K, 2), boundary (N, 2) points and pairs (n, 2) as from fine.match; corner_points
    (4, 2) of the predicted rectangle (shape.corners).  Pair residual r = n_f . (X^-1(s) - b),
    variance sigma^2, f the visible face passing within `reach` [m] of b whose line is nearest
    to s (a reach of a few boundary spacings: the one-to-one matching pairs a point just beyond
    a corner with a boundary point a little way along the other face, which would read as that
    face - an end the scan has not seen - being there).  Edge residual (2,)
    X^-1(e + h/2 d) - k for the visible-face corner k nearest to it, covariance
    sigma^2 I + h^2 / 12 d d^T (+ the corner's from pose_covariance when gating: edges whose
    squared Mahalanobis distance exceeds `gate` are ignored).  A weak prior N(0,
    diag(prior_sigmas)^2) keeps directions no residual constrains at 0 (their variance stays
    ~ the prior's, so the filter ignores them).  Covariance: inverse of the Gauss-Newton
    information matrix.
    """
    centre = np.asarray(centre, float)
    start, direction, length, visible = seen_faces(corner_points, sensor)
    normal = np.column_stack([direction[:, 1], -direction[:, 0]])
    s, b = scan[pairs[:, 0]], boundary[pairs[:, 1]]
    # faces within reach of b (its distance to the segment), the one whose line is nearest to s
    along = np.einsum('nfd,fd->nf', b[:, None, :] - start[None], direction)
    across = np.einsum('nfd,fd->nf', b[:, None, :] - start[None], normal)
    beyond = along - np.clip(along, 0.0, length)   # past the segment's ends, along its line
    on_face = visible & (np.hypot(across, beyond) <= max(reach, 1e-6))
    distance = np.abs(np.einsum('nfd,fd->nf', s[:, None, :] - start[None], normal))
    face = np.argmin(np.where(on_face, distance, np.inf), axis=1)
    keep = on_face[np.arange(len(s)), face]
    s, b, n = s[keep], b[keep], normal[face[keep]]
    b = b - n * across[keep, face[keep]][:, None]   # onto the face's line (within reach of it)
    corner_ids = np.flatnonzero(visible | np.roll(visible, 1))  # corners of visible faces
    expected, corner, weight = gated_edges(edges, corner_points[corner_ids], centre,
                                           pose_covariance, sigma, gate)
    prior = np.diag(1.0 / np.square(prior_sigmas))
    p = np.zeros(3)
    for _ in range(iterations):
        r_inv = rotation(-p[2])
        # X^-1(q) = c + R(-yaw)(q - c - t); d/dt = -R(-yaw), d/dyaw = -J R(-yaw)(q - c - t)
        local = s - centre - p[:2]
        moved = local @ r_inv.T + centre
        residual = np.einsum('nd,nd->n', n, moved - b)
        jac = np.empty((len(s), 3))
        jac[:, :2] = -n @ r_inv
        jac[:, 2] = -np.einsum('nd,nd->n', n, local @ (J @ r_inv).T)
        information = prior + jac.T @ jac / sigma ** 2
        gradient = prior @ p + jac.T @ residual / sigma ** 2
        if len(expected):
            local_e = expected - centre - p[:2]
            r_e = local_e @ r_inv.T + centre - corner
            j_e = np.empty((len(expected), 2, 3))
            j_e[:, :, :2] = -r_inv
            j_e[:, :, 2] = -(local_e @ (J @ r_inv).T)
            weighted = weight @ j_e   # W_e J_e (E, 2, 3); W_e symmetric
            information += np.einsum('eji,ejk->ik', j_e, weighted)
            gradient += np.einsum('eji,ej->i', weighted, r_e)
        step = np.linalg.solve(information, gradient)
        p = p - step
        if np.abs(step).max() < 1e-9:
            break
    if not np.all(np.isfinite(p)):
        raise InvalidInputError('point_to_line: no finite correction')
    return Correction(centre, p[:2].copy(), float(p[2]), np.linalg.inv(information))
