"""Install walker_bringup: bring the walker's node graph up, walk, shut down cleanly."""

from setuptools import find_packages, setup

package_name = 'walker_bringup'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', ['config/fastdds_udp_loopback.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='walker maintainers',
    maintainer_email='maintainers@walker-robot.org',
    description='Bring the walker node graph up as processes, walk, shut down cleanly.',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'composed_graph = walker_bringup.composed_process:main',
        'lossy_link = walker_bringup.lossy_link_node:main',
    ]},
)
