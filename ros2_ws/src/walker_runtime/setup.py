"""Install walker_runtime: the ROS runtime layer every walker node shares."""

from setuptools import find_packages, setup

package_name = 'walker_runtime'

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
    description='The ROS runtime every walker node shares: main, QoS, parameters, spinning.',
    license='Apache-2.0',
    entry_points={'console_scripts': []},
)
