"""Install walker_sim: the pybullet plant that stands in for the walker's hardware."""

from setuptools import find_packages, setup

package_name = 'walker_sim'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='walker maintainers',
    maintainer_email='maintainers@walker-robot.org',
    description='The pybullet plant of the walker: the simulator that stands in for the hardware.',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'plant_node = walker_sim.plant_node:main',
        'identify_modes = walker_sim.identify_modes:main',
        'render_walker = walker_sim.render_walker:main',
    ]},
)
