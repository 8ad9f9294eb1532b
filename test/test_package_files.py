"""Packaging: every node parameter is in config/association.yaml and the README, with its
default; package.xml and setup.cfg have the ament_python layout."""
import pathlib
import xml.etree.ElementTree as ET

import yaml

from data_association_ros.pipelines.parameters import NODE_PARAMETERS

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_config_lists_every_parameter_with_its_default():
    config = yaml.safe_load((ROOT / 'config' / 'association.yaml').read_text())
    values = config['association_node']['ros__parameters']
    assert set(values) == {p.name for p in NODE_PARAMETERS}
    for parameter in NODE_PARAMETERS:
        assert values[parameter.name] == parameter.default, parameter.name
        parameter.check(values[parameter.name])


def test_readme_documents_every_parameter():
    readme = (ROOT / 'README.md').read_text()
    for parameter in NODE_PARAMETERS:
        assert f'| `{parameter.name}` |' in readme, parameter.name


def test_generated_parameter_docs_are_current():
    """config/association.yaml and the README table are what scripts/update_parameter_docs.py
    writes from the declarations."""
    import importlib.util
    spec = importlib.util.spec_from_file_location('update_parameter_docs',
                                                  ROOT / 'scripts' / 'update_parameter_docs.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert (ROOT / 'config' / 'association.yaml').read_text() == module.config_text()
    for name, parameters, page in module.TABLES:   # association, ekf_slam, box, lidar tracker
        assert module.readme_table(parameters) in (ROOT / page).read_text(), name


def test_package_xml_and_setup_cfg():
    package = ET.parse(ROOT / 'package.xml').getroot()
    assert package.get('format') == '3'
    assert package.find('export/build_type').text == 'ament_python'
    depends = {e.text for e in package.findall('exec_depend')}
    assert {'rclpy', 'std_msgs', 'geometry_msgs', 'sensor_msgs', 'nav_msgs', 'visualization_msgs',
            'diagnostic_msgs'} <= depends
    assert 'script_dir=$base/lib/data_association_ros' in (ROOT / 'setup.cfg').read_text()
    assert (ROOT / 'resource' / 'data_association_ros').exists()
