"""Install walker_supervisor: the step-phase supervisor that walks the robot across the truss."""

from setuptools import find_packages, setup

package_name = 'walker_supervisor'

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
    description='Step-phase supervisor of the walker: walking across the truss, step by step.',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'supervisor_node = walker_supervisor.supervisor_node:main',
    ]},
)
