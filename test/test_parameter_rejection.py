"""Every node parameter set at run time to a wrong type or an out-of-range value is refused with
a reason, over the real SetParameters service, and the configuration in force is unchanged."""
import math

from data_association_ros.pipelines.parameters import NODE_PARAMETERS
from test_node import graph, set_parameters  # noqa: F401  (the fixture)


def wrong_values(parameter):
    """Values of the wrong type and out of range for one parameter."""
    default = parameter.default
    values = ['not a number' if not isinstance(default, str) else 3.5]
    if isinstance(default, bool):
        values.append(1.0)
    elif isinstance(default, list):
        values += [[-1.0], [0.1] * 5, [math.inf]]
    elif isinstance(default, str):
        values += ['no_such_value', True]
    else:
        values.append([1.0, 2.0])
        spec = parameter.spec
        if spec.low is not None:
            values.append(type(default)(spec.low - 1))
        if spec.high is not None:
            values.append(type(default)(spec.high + 1))
        if isinstance(default, int):
            values.append(float(default) + 0.5)
    return values


def test_every_parameter_refuses_wrong_types_and_ranges(graph):  # noqa: F811
    before = dict(graph.node.config)
    refused = 0
    for parameter in NODE_PARAMETERS:
        for value in wrong_values(parameter):
            result = set_parameters(graph, **{parameter.name: value})[0]
            assert not result.successful, (parameter.name, value)
            assert result.reason, (parameter.name, value)
            refused += 1
    assert graph.node.config == before
    assert refused > 3 * len(NODE_PARAMETERS)
