"""Measurement models: Jacobians against finite differences, wrapping, inverse of predict."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from data_association_ros.core.models import MODELS, wrap_angle

STEP = 1e-6


def numeric_jacobian(function, x, angular=()):
    """Central differences; differences of angular outputs wrapped to (-pi, pi]."""
    x = np.asarray(x, dtype=float)
    columns = []
    for k in range(x.size):
        dx = np.zeros_like(x)
        dx[k] = STEP
        diff = function(x + dx) - function(x - dx)
        for a in angular:
            diff[a] = wrap_angle(diff[a])
        columns.append(diff / (2 * STEP))
    return np.stack(columns, axis=-1)


finite = st.floats(-20, 20, allow_nan=False)


@pytest.mark.parametrize('name,dim', [('point_map', 2), ('point_map', 3), ('point_robot', 2),
                                      ('range_bearing', 2), ('box', 4)])
@settings(max_examples=60, deadline=None)
@given(landmark=st.lists(finite, min_size=4, max_size=4),
       pose=st.tuples(finite, finite, st.floats(-3.1, 3.1)))
def test_prediction_jacobians_match_finite_differences(name, dim, landmark, pose):
    model = MODELS[name]
    d = model.landmark_dim(dim)
    m = np.array(landmark[:d])
    pose = np.array(pose)
    if name == 'range_bearing' and np.hypot(*(m - pose[:2])) < 0.5:
        return  # the Jacobian is singular at the robot; ranges are never that short
    _, h_m, h_x = model.predict(m[None], pose)
    numeric_m = numeric_jacobian(lambda v: model.predict(v[None], pose)[0][0], m, model.angular)
    numeric_x = numeric_jacobian(lambda p: model.predict(m[None], p)[0][0], pose, model.angular)
    np.testing.assert_allclose(h_m[0], numeric_m, atol=1e-5)
    np.testing.assert_allclose(h_x[0], numeric_x, atol=1e-5)


@pytest.mark.parametrize('name,dim', [('point_map', 2), ('point_robot', 2), ('range_bearing', 2),
                                      ('box', 4)])
@settings(max_examples=60, deadline=None)
@given(landmark=st.lists(finite, min_size=4, max_size=4),
       pose=st.tuples(finite, finite, st.floats(-3.1, 3.1)))
def test_inverse_undoes_predict_and_its_jacobians_match(name, dim, landmark, pose):
    model = MODELS[name]
    m = np.array(landmark[:model.landmark_dim(dim)])
    pose = np.array(pose)
    if name == 'range_bearing' and np.hypot(*(m - pose[:2])) < 0.5:
        return
    z = model.predict(m[None], pose)[0]
    back, j_z, j_x = model.inverse(z, pose)
    np.testing.assert_allclose(back[0], m, atol=1e-9)
    np.testing.assert_allclose(j_z[0], numeric_jacobian(lambda v: model.inverse(v[None], pose)[0][0],
                                                        z[0]), atol=1e-5)
    np.testing.assert_allclose(j_x[0], numeric_jacobian(lambda p: model.inverse(z, p)[0][0], pose),
                               atol=1e-5)


def test_range_bearing_hand_computed():
    model = MODELS['range_bearing']
    h, _, _ = model.predict(np.array([[1.0, 1.0]]), np.array([0.0, 0.0, np.pi / 2]))
    np.testing.assert_allclose(h[0], [np.sqrt(2), -np.pi / 4])


def test_point_robot_hand_computed():
    model = MODELS['point_robot']
    # robot at (1, 2) facing +y: a landmark at (1, 5) is 3 m straight ahead (x forward)
    h, _, _ = model.predict(np.array([[1.0, 5.0]]), np.array([1.0, 2.0, np.pi / 2]))
    np.testing.assert_allclose(h[0], [3.0, 0.0], atol=1e-12)


def test_bearing_innovation_is_wrapped_behind_the_robot():
    model = MODELS['range_bearing']
    # predicted bearing just under +pi, observed just over -pi: the innovation is small
    prediction = np.array([[5.0, np.pi - 0.01]])
    nu = model.innovation(np.array([[5.0, -np.pi + 0.01]]), prediction)
    np.testing.assert_allclose(nu[0, 0], [0.0, 0.02], atol=1e-12)


def test_wrap_angle_range():
    angles = np.array([-np.pi, np.pi, 3 * np.pi, -3 * np.pi + 1e-3, 0.0, 7.0])
    out = wrap_angle(angles)
    assert np.all(out > -np.pi) and np.all(out <= np.pi)
    np.testing.assert_allclose(np.cos(out), np.cos(angles), atol=1e-12)
    assert out[0] == np.pi and out[1] == np.pi


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=1, max_size=20))
def test_wrap_angle_is_in_range_and_the_same_direction(angles):
    angles = np.array(angles)
    out = wrap_angle(angles)
    assert np.all(out > -np.pi) and np.all(out <= np.pi)
    # the same direction: |wrap(a) - a| is a whole number of turns (to the rounding of a)
    turns = (angles - out) / (2 * np.pi)
    np.testing.assert_allclose(turns, np.round(turns), atol=1e-9 * (1 + np.abs(angles).max()))
    inside = (angles > -np.pi) & (angles <= np.pi)
    np.testing.assert_array_equal(out[inside], angles[inside])   # untouched, bit for bit
    for angle, wrapped in zip(angles, out):   # the scalar path agrees with the array path
        assert float(wrap_angle(angle)) == pytest.approx(wrapped, abs=1e-12 * (1 + abs(angle)))


def test_wrap_angle_of_nan_and_inf_is_nan():
    assert np.isnan(wrap_angle(np.array([np.nan, np.inf, -np.inf]))).all()
