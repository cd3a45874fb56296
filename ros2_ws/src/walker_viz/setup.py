"""Install walker_viz: TF and markers of the walker, and its live view in Foxglove."""

from setuptools import find_packages, setup

package_name = 'walker_viz'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config',
         ['config/walker.foxglove.json', 'config/walker.rviz']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='walker maintainers',
    maintainer_email='maintainers@walker-robot.org',
    description='TF, markers and the live Foxglove view of the walker.',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'viz_node = walker_viz.viz_node:main',
        'foxglove_bridge = walker_viz.foxglove_bridge:main',
    ]},
)
