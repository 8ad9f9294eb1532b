"""Time matching: newest not newer within the age limit; nearest within the tolerance."""
from data_association_ros.pipelines.stamped_buffer import StampedBuffer


def test_latest_not_after_and_age_limit():
    buffer = StampedBuffer(capacity=3)
    assert buffer.latest_not_after(5, 10) == (None, 'none received')
    for stamp in (30, 10, 20):  # out of order
        buffer.add(stamp, f'm{stamp}')
    assert buffer.latest_not_after(25, 100) == ('m20', '')
    assert buffer.latest_not_after(20, 0) == ('m20', '')
    assert buffer.latest_not_after(5, 100) == (None, 'all newer than the observation')
    assert buffer.latest_not_after(100, 50) == (None, 'too old')
    buffer.add(40, 'm40')  # capacity 3: the oldest goes
    assert len(buffer) == 3 and buffer.latest_not_after(15, 100)[0] is None


def test_nearest_within_tolerance():
    buffer = StampedBuffer()
    buffer.add(100, 'a')
    buffer.add(200, 'b')
    assert buffer.nearest(160, 50) == ('b', '')
    assert buffer.nearest(140, 50) == ('a', '')
    assert buffer.nearest(150, 10)[0] is None
    buffer.add(200, 'b2')
    assert buffer.nearest(199, 5) == ('b2', '')
