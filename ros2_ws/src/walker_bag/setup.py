"""Install walker_bag: the walk recorder (rosbag2 MCAP bags) and the bag reading helpers."""

from setuptools import find_packages, setup

package_name = 'walker_bag'

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
    description='Records walks as rosbag2 bags in MCAP storage and reads them back.',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'recorder_node = walker_bag.recorder_node:main',
        'bag_info = walker_bag.bag_info:main',
    ]},
)
